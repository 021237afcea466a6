"""Controller configurations as data: the shipped parameter files, or a user's, resolved into one dict.

An episode carries its controller's parameters themselves (node name -> {parameter: value}), not a file
name, so that it is a pure function of its spec wherever it runs (a Dask worker on another machine needs
no copy of the user's file) and its key changes when a parameter does.

Configurations per controller:

- ``wall_follower``: ``sim`` (config/wall_follower_sim.yaml) or ``real`` (config/wall_follower_real.yaml);
- ``navigation`` (explore, localize, plan, follow): ``default`` = the four files the maze_navigation stack
  runs (wall_follower_sim.yaml, path_follower_sim.yaml, planner.yaml, particle_filter.yaml);
- ``localization`` (explore with the wall follower while the particle filter localizes): ``default`` =
  wall_follower_sim.yaml and particle_filter.yaml;
- ``plan_follow`` (plan on the map from the true pose, pure pursuit on the true pose): ``default`` =
  path_follower_sim.yaml and planner.yaml;
- ``fleet_navigation`` (every robot of a world navigating to its goal, with the traffic rules among robots):
  ``default`` = navigation's files and traffic.yaml.
- ``command`` (through ROS only): a user's own node, any executable that speaks ``/scan``, ``/odometry`` and
  ``/cmd_vel`` (seed 002's wall follower lab), run in place of the shipped controller: the configuration is the
  command line (``command=python3 student.py``), kept with the directory it was given in and the hash of every
  file it names, so a changed file is a new configuration (amr_evaluation.ros_episode runs it).

A user's file is a ROS 2 parameter file (``<node>: ros__parameters: ...``, what ``--params-file`` takes)
laid over the controller's default: each of its sections named after one of the controller's nodes
replaces those parameters; a section for a node the controller does not run is refused, and so is a key the node
does not declare, a value of the wrong type or out of its range (amr_evaluation.parameter_check: the node's own
parameter statements), naming the file, the key and the value. For the wall
follower, a file is laid over ``sim`` (``real:my.yaml`` lays it over ``real``).
"""

from __future__ import annotations

import hashlib
import shlex
from pathlib import Path
from typing import Any

import yaml

from amr_evaluation.parameter_check import check_parameters
from amr_util.parameter_file import node_parameters
from amr_util.share import share_directory

CONTROLLERS = ("wall_follower", "navigation", "localization", "plan_follow", "fleet_navigation", "command")
_FILES = {
    "wall_follower": ("amr_control", {"sim": "wall_follower_sim.yaml", "real": "wall_follower_real.yaml"}),
    "path_follower": ("amr_control", {"default": "path_follower_sim.yaml"}),
    "planner": ("amr_planning", {"default": "planner.yaml"}),
    "particle_filter": ("amr_localization", {"default": "particle_filter.yaml"}),
    "navigator": ("amr_navigation", {"default": "navigator.yaml"}),
    "traffic": ("amr_navigation", {"default": "traffic.yaml"}),
}
NODES = {
    "wall_follower": ("wall_follower",),
    "navigation": ("wall_follower", "path_follower", "planner", "particle_filter", "navigator"),
    "localization": ("wall_follower", "particle_filter"),
    "plan_follow": ("path_follower", "planner"),
    "fleet_navigation": ("wall_follower", "path_follower", "planner", "particle_filter", "navigator", "traffic"),
}
"""the nodes whose parameters each controller takes."""


class ConfigurationError(ValueError):
    """An unknown controller or configuration, or a parameter file that cannot be used (named)."""


def shipped_parameters(node: str, variant: str = "default") -> dict[str, Any]:
    """One node's parameters from its shipped file (share/<package>/config, installed by make setup)."""
    package, files = _FILES[node]
    name = files.get(variant, files.get("default") or files["sim"])
    return node_parameters(share_directory(package) / "config" / name, node, ConfigurationError)


def resolve(controller: str, config: str) -> tuple[str, dict[str, dict[str, Any]]]:
    """(label, parameters) of ``controller`` in configuration ``config``: a shipped name, a file, or BASE:FILE.

    The label names the configuration in records and tables: the shipped name, or the file's stem followed
    by 8 hex digits of its content's hash (two versions of one file do not mix in a table), after its base.
    """
    if controller not in CONTROLLERS:
        raise ConfigurationError(f"unknown controller {controller!r} (known: {', '.join(CONTROLLERS)})")
    if controller == "command":
        return command_configuration(config)
    shipped = ("sim", "real") if controller == "wall_follower" else ("default",)
    if config in shipped:
        variant = config if controller == "wall_follower" else "sim"
        return config, {node: shipped_parameters(node, variant) for node in NODES[controller]}
    base, separator, path = config.partition(":")
    if not separator or base not in shipped:
        base, path = shipped[0], config
    file = Path(path)
    if not file.is_file():
        raise ConfigurationError(
            f"{controller}: configuration {config!r} is neither a shipped one ({', '.join(shipped)}) nor a file"
        )
    try:
        data = yaml.safe_load(file.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as problem:
        raise ConfigurationError(f"{file}: cannot read parameter file ({problem})") from problem
    if not isinstance(data, dict) or not data:
        raise ConfigurationError(f"{file}: expected '<node>: ros__parameters: ...' sections")
    unknown = sorted(set(data) - set(NODES[controller]))
    if unknown:
        raise ConfigurationError(
            f"{file}: section {unknown[0]!r} is not a node of the {controller} controller "
            f"(its nodes: {', '.join(NODES[controller])})"
        )
    _, parameters = resolve(controller, base)
    for node in data:
        given = node_parameters(file, node, ConfigurationError)
        check_parameters(file, node, given, ConfigurationError)
        parameters[node] = {**parameters[node], **given}
    digest = hashlib.sha256(file.read_bytes()).hexdigest()[:8]
    return f"{base}:{file.stem}-{digest}", parameters


def command_configuration(text: str, directory: str | Path | None = None) -> tuple[str, dict[str, dict[str, Any]]]:
    """(label, parameters) of a user's controller command (``python3 student.py``): its words, the directory it
    runs in (default: this one) and the sha256 of every word naming a file there. The label is the last such
    file's stem (else the program's name) and 8 hex digits of the command and the files' hashes."""
    if text in ("", "default"):
        raise ConfigurationError(
            "command: give the command that starts your node, e.g. --run 'command=python3 student.py'"
        )
    try:
        words = shlex.split(text)
    except ValueError as problem:
        raise ConfigurationError(f"command {text!r}: {problem}") from problem
    cwd = Path(directory or Path.cwd()).resolve()
    files = {
        word: hashlib.sha256((cwd / word).read_bytes()).hexdigest() for word in words[1:] if (cwd / word).is_file()
    }
    digest = hashlib.sha256("\n".join([text, *(f"{k} {v}" for k, v in sorted(files.items()))]).encode()).hexdigest()
    name = Path(list(files)[-1]).stem if files else Path(words[0]).name
    return f"command:{name}-{digest[:8]}", {"command": {"argv": words, "cwd": str(cwd), "files": files}}
