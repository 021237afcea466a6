"""What a node parameter is: its type, default, description, range, choices, and when it may change.

Plain Python (no rclpy), so the libraries that own a node's configuration can state their
parameters next to their defaults and tests can check them without ROS. `amr_util.managed_node`
turns each spec into its own rcl_interfaces ParameterDescriptor (what `ros2 param describe` and
rqt_reconfigure show) and enforces it on every set.

A spec is `live` (a tunable: gains, speeds, thresholds, noise, timeouts; validated and applied on
the next step or request while the node runs) or structural (world, dt, mode, topics, chains:
refused while the node is configured, because what they shaped is already built). `read_only`
parameters can never change after the node starts.
"""

from __future__ import annotations

import array
import ast
import inspect
import math
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

KINDS = ("bool", "int", "float", "str", "bool_array", "int_array", "float_array", "str_array")


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
    """Inclusive lower bound (numbers, and every element of a numeric array)."""
    maximum: float | None = None
    """Inclusive upper bound."""
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

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", self.kind or kind_of(self.default))
        if self.kind not in KINDS:
            raise ValueError(f"{self.name}: unknown parameter kind {self.kind!r}")

    @property
    def constraint(self) -> str:
        """The limits in words, as descriptions and error messages state them."""
        parts = []
        if self.minimum is not None or self.maximum is not None:
            low = "-inf" if self.minimum is None else _number(self.minimum)
            high = "inf" if self.maximum is None else _number(self.maximum)
            parts.append(f"in [{low}, {high}]")
        if self.choices:
            parts.append("one of " + ", ".join(self.choices))
        return "; ".join(parts)

    def coerce(self, value: Any) -> Any:
        """The value in this parameter's type (an integer for a float is widened), or ValueError naming it."""
        base = self.kind.removesuffix("_array")
        if self.kind.endswith("_array"):
            if not isinstance(value, (list, tuple, array.array)):
                raise ValueError(f"{self.name}: must be a list of {base} values, got {value!r}")
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
                value = float(value)
            ok = isinstance(value, float)
        else:
            ok = isinstance(value, str)
        if not ok:
            raise ValueError(f"{self.name}: must be {_ARTICLE[base]}, got {value!r}")
        return value

    def _check_limits(self, value: Any) -> None:
        values = value if isinstance(value, list) else [value]
        for item in values:
            if isinstance(item, float) and not math.isfinite(item):
                raise ValueError(f"{self.name}: must be finite, got {item!r}")
            low_ok = self.minimum is None or not isinstance(item, (int, float)) or item >= self.minimum
            high_ok = self.maximum is None or not isinstance(item, (int, float)) or item <= self.maximum
            if not (low_ok and high_ok):
                raise ValueError(f"{self.name}: must be {self.constraint}, got {item!r}")
            if self.choices and item not in self.choices:
                raise ValueError(f"{self.name}: must be {self.constraint}, got {item!r}")
        if self.check is not None:
            problem = self.check(value)
            if problem:
                raise ValueError(f"{self.name}: {problem}")


def _number(value: float) -> str:
    return str(value) if isinstance(value, int) else f"{value:g}"


_ARTICLE = {"bool": "true or false", "int": "an integer", "float": "a number", "str": "a string"}


def field_docs(cls: type) -> dict[str, str]:
    """{field: docstring} of a dataclass, from the string literal under each field in its source.

    The configuration dataclasses document every field where it is defined; descriptors take
    those words instead of a second copy that would drift.
    """
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body
    docs: dict[str, str] = {}
    for statement, following in zip(body, body[1:]):
        if (isinstance(statement, ast.AnnAssign) and isinstance(statement.target, ast.Name)
                and isinstance(following, ast.Expr) and isinstance(following.value, ast.Constant)
                and isinstance(following.value.value, str)):
            docs[statement.target.id] = " ".join(following.value.value.split())
    return docs


def problems_of(specs: Sequence[ParameterSpec], values: dict[str, Any]) -> list[str]:
    """Every per-key problem of `values` against `specs`, all at once (not just the first)."""
    problems = []
    for spec in specs:
        if spec.name in values:
            try:
                spec.coerce(values[spec.name])
            except ValueError as problem:
                problems.append(str(problem))
    return problems
