"""The parameters panel's model: any node's parameters from their descriptors, as widgets; no rclpy, no viser.

What a node says through the standard services (rcl_interfaces ListParameters, DescribeParameters, GetParameters)
becomes one ParameterEntry per parameter: a slider where the descriptor gives a bounded range, a number field where it
does not, a checkbox, a text field (strings, and arrays as YAML lists), or read-only text. A set goes out as the
parameter's own type; what the node answers (its refusal and reason) is shown as it gives it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import yaml
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue

SLIDER_MAX_SPAN = 1e6
"""A range wider than this (ours say +-1e308 for 'unbounded' on one side) gets a number field, not a slider."""
SLIDER_STEPS = 200
STRUCTURAL_MARK = "(structural"
"""How this suite's descriptors mark parameters a configured node refuses (amr_util.managed_node.descriptor_of)."""
HIDDEN_PREFIXES = ("qos_overrides.",)

VALUE_FIELDS = {
    ParameterType.PARAMETER_BOOL: "bool_value",
    ParameterType.PARAMETER_INTEGER: "integer_value",
    ParameterType.PARAMETER_DOUBLE: "double_value",
    ParameterType.PARAMETER_STRING: "string_value",
    ParameterType.PARAMETER_BYTE_ARRAY: "byte_array_value",
    ParameterType.PARAMETER_BOOL_ARRAY: "bool_array_value",
    ParameterType.PARAMETER_INTEGER_ARRAY: "integer_array_value",
    ParameterType.PARAMETER_DOUBLE_ARRAY: "double_array_value",
    ParameterType.PARAMETER_STRING_ARRAY: "string_array_value",
}
ARRAY_ITEMS = {
    ParameterType.PARAMETER_BOOL_ARRAY: bool,
    ParameterType.PARAMETER_INTEGER_ARRAY: int,
    ParameterType.PARAMETER_DOUBLE_ARRAY: float,
    ParameterType.PARAMETER_STRING_ARRAY: str,
}


@dataclass
class ParameterEntry:
    name: str
    type: int
    """rcl_interfaces/ParameterType"""
    value: object
    description: str = ""
    read_only: bool = False
    widget: str = "text"
    """slider | number | checkbox | text | readonly"""
    minimum: float | None = None
    maximum: float | None = None
    step: float | None = None

    @property
    def structural(self) -> bool:
        return STRUCTURAL_MARK in self.description

    @property
    def is_integer(self) -> bool:
        return self.type == ParameterType.PARAMETER_INTEGER

    def text(self) -> str:
        return format_value(self.value)

    def parse(self, given: object) -> object:
        """A widget's value (or typed text) as this parameter's type; ValueError saying what was expected."""
        kind = self.type
        try:
            if kind == ParameterType.PARAMETER_BOOL:
                if isinstance(given, str):
                    loaded = yaml.safe_load(given)
                    if not isinstance(loaded, bool):
                        raise ValueError
                    return loaded
                return bool(given)
            if kind == ParameterType.PARAMETER_INTEGER:
                value = float(given)
                if not value.is_integer():
                    raise ValueError
                return int(value)
            if kind == ParameterType.PARAMETER_DOUBLE:
                return float(given)
            if kind == ParameterType.PARAMETER_STRING:
                return str(given)
            if kind in ARRAY_ITEMS:
                return _parse_array(given, ARRAY_ITEMS[kind])
        except (TypeError, ValueError, yaml.YAMLError):
            pass
        raise ValueError(f"{self.name}: {given!r} is not {TYPE_WORDS.get(kind, 'a value of its type')}")

    def message(self, value: object) -> Parameter:
        """rcl_interfaces/Parameter setting this parameter to `value` (already parsed)."""
        return Parameter(name=self.name, value=parameter_value(self.type, value))


TYPE_WORDS = {
    ParameterType.PARAMETER_BOOL: "true or false",
    ParameterType.PARAMETER_INTEGER: "an integer",
    ParameterType.PARAMETER_DOUBLE: "a number",
    ParameterType.PARAMETER_STRING: "a string",
    ParameterType.PARAMETER_BOOL_ARRAY: "a list of true/false",
    ParameterType.PARAMETER_INTEGER_ARRAY: "a list of integers",
    ParameterType.PARAMETER_DOUBLE_ARRAY: "a list of numbers",
    ParameterType.PARAMETER_STRING_ARRAY: "a list of strings",
}


def _parse_array(given: object, item: type) -> list:
    loaded = yaml.safe_load(given) if isinstance(given, str) else given
    if loaded is None:
        loaded = []
    if not isinstance(loaded, (list, tuple)):
        raise ValueError
    values = []
    for element in loaded:
        if item is float and isinstance(element, (int, float)) and not isinstance(element, bool):
            values.append(float(element))
        elif item is int and isinstance(element, int) and not isinstance(element, bool):
            values.append(element)
        elif item is bool and isinstance(element, bool):
            values.append(element)
        elif item is str and isinstance(element, (str, int, float)) and not isinstance(element, bool):
            values.append(str(element))
        else:
            raise ValueError
    return values


def format_value(value: object) -> str:
    """A value as a user types it: YAML scalars, lists in brackets."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_value(v) if not isinstance(v, str) else _quoted(v) for v in value) + "]"
    return str(value)


def _quoted(text: str) -> str:
    plain = yaml.safe_dump(text, default_style=None).strip().removesuffix("...").strip()
    return plain


def value_of(message: ParameterValue) -> object:
    """A ParameterValue as a Python value (lists for arrays), None when not set."""
    field = VALUE_FIELDS.get(message.type)
    if field is None:
        return None
    value = getattr(message, field)
    return list(value) if message.type in ARRAY_ITEMS or message.type == ParameterType.PARAMETER_BYTE_ARRAY else value


def parameter_value(kind: int, value: object) -> ParameterValue:
    message = ParameterValue(type=kind)
    setattr(message, VALUE_FIELDS[kind], value)
    return message


def nice_step(span: float, steps: int = SLIDER_STEPS) -> float:
    """1, 2 or 5 x 10^k, about span / steps."""
    if not (span > 0.0 and math.isfinite(span)):
        return 1.0
    raw = span / steps
    power = 10.0 ** math.floor(math.log10(raw))
    for multiple in (1.0, 2.0, 5.0, 10.0):
        if raw <= multiple * power:
            return multiple * power
    return 10.0 * power


def entry_from(name: str, descriptor, value: ParameterValue) -> ParameterEntry:
    """A panel entry from a node's descriptor and value of one parameter."""
    kind = value.type if value.type != ParameterType.PARAMETER_NOT_SET else descriptor.type
    entry = ParameterEntry(name, kind, value_of(value), descriptor.description, bool(descriptor.read_only))
    if entry.read_only or kind in (ParameterType.PARAMETER_NOT_SET, ParameterType.PARAMETER_BYTE_ARRAY):
        entry.widget = "readonly"
    elif kind == ParameterType.PARAMETER_BOOL:
        entry.widget = "checkbox"
    elif kind in (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_INTEGER):
        entry.widget = "number"
        ranges = descriptor.floating_point_range if kind == ParameterType.PARAMETER_DOUBLE else descriptor.integer_range
        if ranges:
            low, high, step = ranges[0].from_value, ranges[0].to_value, ranges[0].step
            entry.minimum, entry.maximum = low, high
            if (
                math.isfinite(low)
                and math.isfinite(high)
                and 0 < high - low <= SLIDER_MAX_SPAN
                and isinstance(entry.value, (int, float))
                and low <= entry.value <= high
            ):
                entry.widget = "slider"
                entry.step = (
                    step if step > 0 else (1 if kind == ParameterType.PARAMETER_INTEGER else nice_step(high - low))
                )
    return entry


def entries_from(names: list[str], descriptors, values) -> list[ParameterEntry] | None:
    """The panel's entries of a node's parameters `names` from its DescribeParameters descriptors and GetParameters
    values (in the same order); None when the counts differ (rclpy answers none for all when one is undeclared or
    unset)."""
    if not len(names) == len(descriptors) == len(values):
        return None
    return [
        entry_from(name, descriptor, value) for name, descriptor, value in zip(names, descriptors, values, strict=True)
    ]


def visible(name: str) -> bool:
    return not name.startswith(HIDDEN_PREFIXES)
