"""A sweep's parameter file checked against the nodes' own parameter statements, before any episode is dispatched.

Each section of a user's file (``<node>: ros__parameters: ...``) is held to the ``ParameterSpec``s that node
declares (amr_util.parameter_spec: the very statements its ROS node declares, with their types, ranges and
choices): an unknown key, a value of the wrong type or out of range is an error naming the file, the key and
the value, instead of an episode that fails on a worker (or, worse, a key silently ignored by the library loop).
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from amr_util.parameter_file import dotted
from amr_util.parameter_spec import ConfigError, ParameterSpec

ROS_PARAMETERS = frozenset({"use_sim_time"})
"""Parameters every ROS node has besides its own (rclpy declares them)."""


def node_specs(node: str) -> tuple[ParameterSpec, ...]:
    """The parameter statements of `node` (a node of configs.NODES), as that node declares them."""
    if node == "wall_follower":
        from amr_control.wall_follower_config import WallFollowerConfig

        return WallFollowerConfig.parameter_specs()
    if node == "path_follower":
        from amr_control.path_follower_config import PathFollowerConfig

        return PathFollowerConfig.parameter_specs()
    if node == "planner":
        from amr_planning.planner import PlannerConfig

        return PlannerConfig.parameter_specs()
    if node == "navigator":
        from amr_navigation.navigator_config import NavigatorConfig

        return NavigatorConfig.parameter_specs()
    if node == "traffic":  # the navigators' traffic rules (amr_navigation.traffic), as the fleet loop reads them
        from amr_navigation.traffic import TrafficConfig

        return TrafficConfig.parameter_specs()
    if node == "particle_filter":  # the filter's own parameters and its node shell's (frames, pairing)
        from amr_localization.localizer_node import SHELL_SPECS
        from amr_localization.particle_filter_parameters import parameter_specs

        return parameter_specs() + SHELL_SPECS
    raise KeyError(f"no parameter statements for node {node!r}")


def parameter_problems(node: str, values: Mapping[str, Any]) -> list[str]:
    """Every problem of `values` (flat or nested) for `node`: '<key> = <value>: <what is wrong>' each."""
    specs = {spec.name: spec for spec in node_specs(node)}
    problems = []
    for key, value in dotted(dict(values)).items():
        spec = specs.get(key)
        if spec is None:
            if key in ROS_PARAMETERS:
                continue
            close = difflib.get_close_matches(key, specs, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else f" (known: {', '.join(sorted(specs))})"
            problems.append(f"{key} = {value!r}: unknown key of {node}{hint}")
            continue
        try:
            spec.coerce(value)
        except ConfigError as error:
            rule = str(error).removeprefix(f"{key}: ")
            problems.append(f"{key} = {value!r}: {rule}")
    return problems


def check_parameters(file: str | Path, node: str, values: Mapping[str, Any], error: type[Exception]) -> None:
    """`error` naming `file`, `node` and every bad key with its value, if `values` are not all `node`'s."""
    problems = parameter_problems(node, values)
    if problems:
        raise error(f"{file}: {node}: " + "; ".join(problems))
