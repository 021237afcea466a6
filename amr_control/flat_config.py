"""A controller's configuration as one flat dict of ROS parameters, every key known and typed (no ROS).

The wall follower and the path follower each keep a frozen dataclass of their parameters (defaults
and docstrings are the documentation); this base gives both the same reading: unknown keys and
wrong types raise ConfigError naming the key, so a typo never falls back to a default.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Mapping

from amr_util.parameter_file import node_parameters


class ConfigError(ValueError):
    """A controller parameter is missing its type, range or name."""


class FlatConfig:
    """Base of a frozen dataclass of scalar parameters (bool, int, float, str)."""

    @classmethod
    def from_params(cls, params: Mapping[str, Any]):
        """Build from a flat parameter dict; every key must be known and typed right."""
        fields = {f.name: f for f in dataclasses.fields(cls)}
        values: dict[str, Any] = {}
        for key, value in params.items():
            if key not in fields:
                raise ConfigError(f"{key}: unknown parameter (known: {', '.join(sorted(fields))})")
            values[key] = typed(key, fields[key].type, value)
        return cls(**values)

    @classmethod
    def read(cls, path: str | Path, node_name: str):
        """The config in a ROS 2 parameter YAML file (``<node_name>: ros__parameters: ...``)."""
        return cls.from_params(node_parameters(path, node_name, ConfigError))

    def as_params(self) -> dict[str, Any]:
        """The flat parameter dict (what a node declares)."""
        return dataclasses.asdict(self)


def typed(key: str, kind: str, value: Any) -> Any:
    """`value` checked against a field's annotated kind; an integer for a float is widened."""
    if kind == "bool":
        if not isinstance(value, bool):
            raise ConfigError(f"{key}: must be true or false, got {value!r}")
        return value
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{key}: must be an integer, got {value!r}")
        return value
    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{key}: must be a number, got {value!r}")
        return float(value)
    if not isinstance(value, str):
        raise ConfigError(f"{key}: must be a string, got {value!r}")
    return value
