"""Reading one node's section of a ROS 2 parameter YAML file without ROS (tests, benchmarks, tools)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml


def node_parameters(path: str | Path, node_name: str, error: type[Exception] = ValueError) -> dict[str, Any]:
    """The `<node_name>: ros__parameters:` mapping of a file; `error` (naming the file) if it has none."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
        params = data[node_name]["ros__parameters"]
    except (OSError, yaml.YAMLError) as problem:
        raise error(f"{path}: cannot read parameter file ({problem})") from problem
    except (KeyError, TypeError) as problem:
        raise error(f"{path}: no '{node_name}: ros__parameters:' section") from problem
    if not isinstance(params, dict):
        raise error(f"{path}: '{node_name}: ros__parameters:' is not a mapping")
    return params


def dotted(params: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested mappings to ROS's dotted names: {'lidar': {'beams': 240}} -> {'lidar.beams': 240}."""
    flat: dict[str, Any] = {}
    for key, value in params.items():
        if isinstance(value, Mapping):
            flat.update(dotted(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat
