"""What a node parameter is, stated once: its type, default, range or choices, description, and when it may change.

Plain Python (no rclpy), so the libraries that own a node's configuration state their parameters
next to the code they steer, and tests check them without ROS.

A configuration is a frozen dataclass deriving from `Config`, one field per parameter:

    @dataclass(frozen=True)
    class WallFollowerConfig(Config):
        kp: float = parameter(4.0, minimum=0.0, maximum=100.0, live=True)
        \"\"\"rad/s per m of distance error.\"\"\"

The annotation is the type, the field's default is the default, the docstring under the field is
the description, and `parameter(...)` holds the rest: range (`minimum`/`maximum` inclusive,
`above`/`below` exclusive), `choices`, `live`, an extra `check`. From that one statement come
- validation: every construction checks each field (`ConfigError` naming the key, the rule and the
  value), then the class's `validate()` checks what relates several fields;
- `from_params` (a flat ROS parameter dict, dotted names for nested sections, unknown keys refused)
  and `read` (a ROS 2 parameter YAML file);
- `parameter_specs()`: one `ParameterSpec` per parameter, from which `amr_util.managed_node` makes
  each ROS descriptor (what `ros2 param describe` and rqt_reconfigure show) and enforces every set;
- the docs' parameter tables (`amr_util.parameter_docs`).

A parameter is `live` (a tunable: gains, speeds, thresholds, noise, timeouts; validated and applied
on the next step or request while the node runs) or structural (world, dt, mode, topics, chains:
refused while the node is configured, because what they shaped is already built). `read_only`
parameters can never change after the node starts.

Node parameters with no library configuration behind them (topics, frames, a recorder's path) are
`ParameterSpec`s written directly, one statement each.
"""

from __future__ import annotations

import array
import ast
import dataclasses
import functools
import inspect
import itertools
import math
import textwrap
import typing
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from amr_util.parameter_file import dotted, node_parameters

KINDS = ("bool", "int", "float", "str", "bool_array", "int_array", "float_array", "str_array")
SPEC = "amr_util.parameter_spec"
"""The dataclass field metadata key under which `parameter()` keeps a field's spec."""


class ConfigError(ValueError):
    """A parameter that is unknown, of the wrong type or out of range; the message names the key (and file)."""


def kind_of(value: Any) -> str:
    """The ROS parameter kind of a Python default value (a list's kind from its first element)."""
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "int"
    if isinstance(value, float):
        return "float"
    if isinstance(value, str):
        return "str"
    if isinstance(value, (list, tuple)) and value:
        return kind_of(value[0]) + "_array"
    raise TypeError(f"no parameter kind for default {value!r}: give `kind` explicitly")


@dataclass(frozen=True)
class ParameterSpec:
    """One parameter: name, default (its type), description, limits, and when it may change."""

    name: str
    default: Any
    description: str = ""
    minimum: float | None = None
    """Lower bound (numbers, and every element of a numeric array); inclusive unless exclusive_minimum."""
    maximum: float | None = None
    """Upper bound; inclusive unless exclusive_maximum."""
    choices: tuple[str, ...] = ()
    """For strings: the values allowed."""
    live: bool = False
    """True: may change while configured and takes effect at once; False: refused while configured."""
    read_only: bool = False
    """True: fixed once the node has started (declared read-only)."""
    kind: str = ""
    """One of KINDS; inferred from the default when empty."""
    check: Callable[[Any], str | None] | None = field(default=None, compare=False)
    """An extra check of the value: returns a problem (e.g. "no such file") or None."""
    exclusive_minimum: bool = False
    exclusive_maximum: bool = False
    integers_as_floats: bool = True
    """False: an integer where a float is wanted is refused, saying how to write it (`1.0`)."""
    nonempty: bool = False
    """A string (or each string of an array) must not be empty, and an array must have an element."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", self.kind or kind_of(self.default))
        if self.kind not in KINDS:
            raise ValueError(f"{self.name}: unknown parameter kind {self.kind!r}")

    @property
    def range_text(self) -> str:
        """The numeric limits in words: 'in [0, 100]', 'in (0, 60]', '>= 0', '> 0', '<= 5', or ''."""
        low, high = self.minimum, self.maximum
        if low is not None and high is not None:
            return (
                f"in {'(' if self.exclusive_minimum else '['}{_number(low)}, "
                f"{_number(high)}{')' if self.exclusive_maximum else ']'}"
            )
        if low is not None:
            return f"{'>' if self.exclusive_minimum else '>='} {_number(low)}"
        if high is not None:
            return f"{'<' if self.exclusive_maximum else '<='} {_number(high)}"
        return ""

    @property
    def constraint(self) -> str:
        """The limits in words, as descriptions and error messages state them."""
        parts = [self.range_text] if self.range_text else []
        if self.choices:
            parts.append("one of " + ", ".join(self.choices))
        return "; ".join(parts)

    def coerce(self, value: Any) -> Any:
        """The value in this parameter's type (an integer for a float is widened), or ConfigError naming it."""
        base = self.kind.removesuffix("_array")
        if self.kind.endswith("_array"):
            if not isinstance(value, (list, tuple, array.array)) or (self.nonempty and not len(value)):
                raise ConfigError(
                    f"{self.name}: must be {'a non-empty' if self.nonempty else 'a'} list of "
                    f"{_PLURAL[base] if not self.nonempty or base != 'str' else 'non-empty strings'}, "
                    f"got {value!r}"
                )
            value = [self._scalar(base, item) for item in value]
        else:
            value = self._scalar(base, value)
        self._check_limits(value)
        return value

    def _scalar(self, base: str, value: Any) -> Any:
        if base == "bool":
            ok = isinstance(value, bool)
        elif base == "int":
            ok = isinstance(value, int) and not isinstance(value, bool)
        elif base == "float":
            if isinstance(value, int) and not isinstance(value, bool):
                if not self.integers_as_floats:
                    raise ConfigError(
                        f"{self.name}: {value!r} is an integer where a float is required: write {value}.0 (rclpy "
                        f"reads [1, 2] as an integer array and refuses a list mixing 1 and 2.5)"
                    )
                value = float(value)
            ok = isinstance(value, float)
        else:
            ok = isinstance(value, str) and (bool(value) or not self.nonempty)
        if not ok:
            article = "a non-empty string" if base == "str" and self.nonempty else _ARTICLE[base]
            raise ConfigError(f"{self.name}: must be {article}, got {value!r}")
        return value

    def _check_limits(self, value: Any) -> None:
        values = value if isinstance(value, list) else [value]
        for item in values:
            if isinstance(item, float) and not math.isfinite(item):
                raise ConfigError(f"{self.name}: must be finite, got {item!r}")
            if isinstance(item, (int, float)) and not isinstance(item, bool):
                problem = self._bounds_problem(item)
                if problem:
                    raise ConfigError(f"{self.name}: must be {problem}, got {item!r}")
            if self.choices and item not in self.choices:
                raise ConfigError(f"{self.name}: must be one of {', '.join(self.choices)}, got {item!r}")
        if self.check is not None:
            problem = self.check(value)
            if problem:
                raise ConfigError(f"{self.name}: {problem}")

    def _bounds_problem(self, item: float) -> str:
        """'' when within the limits; else the rule broken, as words after 'must be'."""
        low, high = self.minimum, self.maximum
        below = low is not None and (item < low or (self.exclusive_minimum and item == low))
        above = high is not None and (item > high or (self.exclusive_maximum and item == high))
        if not (below or above):
            return ""
        limits = self.range_text
        if below and low == 0 and self.exclusive_minimum:
            return "positive" + ("" if high is None else f" ({limits})")
        if below and low == 0:
            return ">= 0" + ("" if high is None else f" ({limits})")
        return limits


def _number(value: float) -> str:
    return str(value) if isinstance(value, int) else f"{value:g}"


_ARTICLE = {"bool": "true or false", "int": "an integer", "float": "a number", "str": "a string"}
_PLURAL = {"bool": "true/false values", "int": "integers", "float": "numbers", "str": "strings"}


# -- parameters as dataclass fields ------------------------------------------------------------


def parameter(
    default: Any = dataclasses.MISSING,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    above: float | None = None,
    below: float | None = None,
    choices: Sequence[str] = (),
    live: bool = False,
    read_only: bool = False,
    kind: str = "",
    nonempty: bool = False,
    integers_as_floats: bool = True,
    check: Callable[[Any], str | None] | None = None,
):
    """A dataclass field that is a parameter: its default, limits, and whether it is live.

    `minimum`/`maximum` are inclusive bounds, `above`/`below` exclusive ones (`above=0.0`: positive).
    The description is the docstring under the field; the type is its annotation (a list default, or
    None for "not given", states its kind, e.g. kind="float_array"). A list default is copied per instance.
    """
    if (minimum is not None and above is not None) or (maximum is not None and below is not None):
        raise TypeError("give minimum or above, maximum or below, not both")
    if default is None and not kind:
        raise TypeError("a parameter defaulting to None needs `kind`")
    ros_default = [] if default is None else list(default) if isinstance(default, tuple) else default
    spec = ParameterSpec(
        "",
        ros_default,
        minimum=minimum if above is None else above,
        maximum=maximum if below is None else below,
        exclusive_minimum=above is not None,
        exclusive_maximum=below is not None,
        choices=tuple(choices),
        live=live,
        read_only=read_only,
        kind=kind,
        nonempty=nonempty,
        integers_as_floats=integers_as_floats,
        check=check,
    )
    if isinstance(default, list):
        return field(default_factory=functools.partial(list, default), metadata={SPEC: spec})
    return field(default=default, metadata={SPEC: spec})


def parameter_like(cls: type, name: str, **changes: Any):
    """A parameter field stated by another Config's field: its default, limits and description (unless
    this field has a docstring of its own). E.g. the planner node's flat `prm_node_count` is
    RoadmapConfig's `node_count`; `changes` add what only the node says (live=True)."""
    spec = dataclasses.replace({s.name: s for s in _own_specs(cls)}[name], name="", **changes)
    return field(default=_field(cls, name).default, metadata={SPEC: spec})


def field_docs(cls: type) -> dict[str, str]:
    """{field: docstring} of a dataclass, from the string literal under each field in its source.

    The configuration dataclasses document every field where it is defined; specs, descriptors and
    the docs' tables take those words instead of a second copy that would drift.
    """
    return dict(_field_docs(cls))


@functools.cache
def _field_docs(cls: type) -> tuple[tuple[str, str], ...]:
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if not dataclasses.is_dataclass(klass):
            continue
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        except (OSError, TypeError):  # no source (an interactive class): no descriptions
            continue
        body = tree.body[0].body
        for statement, following in itertools.pairwise(body):
            if (
                isinstance(statement, ast.AnnAssign)
                and isinstance(statement.target, ast.Name)
                and isinstance(following, ast.Expr)
                and isinstance(following.value, ast.Constant)
                and isinstance(following.value.value, str)
            ):
                docs[statement.target.id] = " ".join(following.value.value.split())
    return tuple(docs.items())


def _sections(cls: type) -> dict[str, type]:
    """{field: Config class} of the fields that are nested configurations (dotted names: 'lidar.beams')."""
    hints = typing.get_type_hints(cls)
    return {
        f.name: hints[f.name]
        for f in dataclasses.fields(cls)
        if isinstance(hints.get(f.name), type) and issubclass(hints[f.name], Config)
    }


_ANNOTATED_KINDS = {bool: "bool", int: "int", float: "float", str: "str"}


@functools.cache
def _own_specs(cls: type) -> tuple[ParameterSpec, ...]:
    """The specs of cls's own parameter fields, named and described (nested sections not included).

    A scalar field's annotation must be its default's type: `kp: float = parameter(4)` is refused
    here, at import, rather than declared to ROS as an integer parameter.
    """
    docs = field_docs(cls)
    hints = typing.get_type_hints(cls)
    specs = []
    for f in dataclasses.fields(cls):
        spec = f.metadata.get(SPEC)
        if spec is None:
            continue
        annotated = _ANNOTATED_KINDS.get(hints.get(f.name))
        if annotated and annotated != spec.kind:
            raise TypeError(
                f"{cls.__name__}.{f.name}: annotated {annotated}, but its default {spec.default!r} is {spec.kind}"
            )
        specs.append(dataclasses.replace(spec, name=f.name, description=docs.get(f.name) or spec.description))
    return tuple(specs)


def specs_of(cls: type, prefix: str = "") -> tuple[ParameterSpec, ...]:
    """Every parameter of a Config class, nested sections as dotted names, in field order."""
    own = {spec.name: spec for spec in _own_specs(cls)}
    sections = _sections(cls)
    specs: list[ParameterSpec] = []
    for f in dataclasses.fields(cls):
        if f.name in own:
            specs.append(dataclasses.replace(own[f.name], name=prefix + f.name))
        elif f.name in sections:
            specs.extend(specs_of(sections[f.name], f"{prefix}{f.name}."))
    return tuple(specs)


class Config:
    """Base of a frozen dataclass of parameters (fields made with `parameter()`, or nested Configs).

    Construction validates every field against its spec, then calls `validate()` for the checks that
    relate several fields; both raise ConfigError naming the key.
    """

    def __post_init__(self) -> None:
        optional = _optional(type(self))
        for spec in _own_specs(type(self)):
            value = getattr(self, spec.name)
            if value is None and spec.name in optional:
                continue  # "not given" (e.g. the world's own start)
            checked = spec.coerce(value)
            if spec.name in optional:  # an array that may be "not given": a tuple, or None for []
                checked = tuple(checked) or None
            elif isinstance(value, tuple):
                checked = tuple(checked)
            if type(checked) is not type(value) or checked != value:
                object.__setattr__(self, spec.name, checked)
        self.validate()

    def validate(self) -> None:
        """Checks relating several fields; raise ConfigError naming the key."""

    @classmethod
    def parameter_specs(cls) -> tuple[ParameterSpec, ...]:
        """One spec per parameter (dotted names for nested sections), in field order."""
        return specs_of(cls)

    @classmethod
    def from_params(cls, params: Mapping[str, Any], ignore: Iterable[str] = ()):
        """Build from a flat dict of ROS parameters (dotted names, or nested dicts); every key must be
        known and typed right (an integer for a float is widened), so a typo never falls back to a default."""
        skip = set(ignore)
        flat = {key: value for key, value in dotted(params).items() if key not in skip}
        return cls._build(flat, "")

    @classmethod
    def _build(cls, flat: Mapping[str, Any], prefix: str):
        own = {spec.name: spec for spec in _own_specs(cls)}
        sections = _sections(cls)
        values: dict[str, Any] = {}
        nested: dict[str, dict[str, Any]] = {}
        for key, value in flat.items():
            head, dot, rest = key.partition(".")
            if dot and head in sections:
                nested.setdefault(head, {})[rest] = value
            elif key in own:
                values[key] = dataclasses.replace(own[key], name=prefix + key).coerce(value)
            elif dot and head in own:
                raise ConfigError(f"{prefix}{key}: unknown parameter ({prefix}{head} has no sub-parameters)")
            else:
                known = sorted(set(own) | {f"{name}.*" for name in sections})
                raise ConfigError(f"{prefix}{key}: unknown parameter (known: {', '.join(known)})")
        for name, section in sections.items():
            if name in nested:
                values[name] = section._build(nested[name], f"{prefix}{name}.")
        try:
            return cls(**values)
        except ConfigError as error:
            if not prefix:
                raise
            raise ConfigError(prefix + str(error)) from None

    @classmethod
    def read(cls, path: str | Path, node_name: str):
        """The config in a ROS 2 parameter YAML file (``<node_name>: ros__parameters: ...``)."""
        return cls.from_params(node_parameters(path, node_name, ConfigError))

    def structural_changes(self, other: Config) -> list[str]:
        """The structural (not live) parameters whose values differ in `other`: what a running user of
        this config (a built filter, a stepping simulator) cannot take without being built anew."""
        mine, theirs = self.as_params(), other.as_params()
        return [
            spec.name
            for spec in self.parameter_specs()
            if not spec.live and mine.get(spec.name) != theirs.get(spec.name)
        ]

    def as_params(self) -> dict[str, Any]:
        """The flat parameter dict (what a node declares): dotted names, None ("not given") left out."""
        params: dict[str, Any] = {}
        sections = _sections(type(self))
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name in sections:
                params.update({f"{f.name}.{key}": item for key, item in value.as_params().items()})
            elif value is not None:
                params[f.name] = list(value) if isinstance(value, tuple) else value
        return params


def _field(cls: type, name: str) -> dataclasses.Field:
    return next(f for f in dataclasses.fields(cls) if f.name == name)


@functools.cache
def _optional(cls: type) -> frozenset[str]:
    """Fields whose default is None: "not given" is a valid value of theirs."""
    return frozenset(f.name for f in dataclasses.fields(cls) if f.default is None)


def problems_of(specs: Sequence[ParameterSpec], values: dict[str, Any]) -> list[str]:
    """Every per-key problem of `values` against `specs`, all at once (not just the first)."""
    problems = []
    for spec in specs:
        if spec.name in values:
            try:
                spec.coerce(values[spec.name])
            except ConfigError as problem:
                problems.append(str(problem))
    return problems
