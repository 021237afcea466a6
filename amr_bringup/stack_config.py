"""The bringup file: which nodes make a stack, with which parameters, in which lifecycle order.

One YAML per stack (config/bringup/*.yaml) feeds both `amr-bringup` and the ROS launch
files in launch/, so the node lists and parameters have one source. The format:

    nodes:                                   # started in this order
      - name: wall_follower                  # ROS node name (required)
        package: amr_control                 # ament package (required)
        executable: wall_follower            # lib/<package>/<executable> (required)
        namespace: ""                        # optional, "" = the root namespace
        parameter_files: [wall_follower_sim.yaml]  # relative: share/<package>/config/<file>
        parameters: {preferred_wall: left}   # optional inline parameters, after the files
        remappings: {cmd_vel: /robot/cmd_vel}  # optional, from: to
        per_robot: false                     # optional: true = one copy per robot of the world (below)
    lifecycle_manager:                       # optional
      node_startup_order: [wall_follower]    # default: every node, in the order listed
      wait_timeout: 30.0                     # optional, s, passed to the manager
      transition_timeout: 15.0               # optional, s
    robots_from: simulator.world             # with a per_robot node: the <node>.<parameter> naming the world
    arguments:                               # optional: what a user changes per run
      preferred_wall:                        # `amr-bringup <stack> preferred_wall:=left`,
        sets: [wall_follower.preferred_wall] # `ros2 launch ... preferred_wall:=left`
        description: right, left or random
        clears: []                           # optional: <node>.<parameter>s set to '' when it is given

A node with `per_robot: true` is a description of every robot's copy: when the stack is made (`with_overrides`,
which amr-bringup, `ros2 launch` and `composed_stack` all call), `robot_nodes` maps the robots of the world that
`robots_from` names (amr_maps.world.World.fleet) to one copy each in the robot's namespace (`/r1/wall_follower`),
and the copies take the template's place in the lifecycle order, robot by robot. A world without a `robots` list
is one unnamed robot: one copy in the template's own namespace, exactly as a node without per_robot.
A per_robot node's parameter whose value is the string `{robot_index}` gets, in each copy, the robot's index in
the world's `robots` list (0 for the first, and for the one robot of a world without the list): the navigator's
traffic `priority`.

Every stack also has the arguments `use_sim_time` (every node) and `<node>_params_file` (replaces
that node's parameter files). An argument left unset changes nothing: the files decide.

Parsing checks the structure and names the file and key of anything wrong; `check_installed`
then checks what the ament index must hold (packages, executables, parameter files).
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import yaml
from ament_index_python.packages import PackageNotFoundError

from amr_bringup.lifecycle_sequence import MANAGER_PARAMETERS
from amr_util.parameter_file import dotted, node_parameters
from amr_util.parameter_spec import ConfigError
from amr_util.share import package_prefix, share_directory

BRINGUP_PACKAGE = "amr_bringup"
"""The package whose share/<package>/config/bringup holds the shipped bringup files."""
NODE_KEYS = {"name", "package", "executable", "namespace", "parameter_files", "parameters", "remappings", "per_robot"}
REQUIRED_NODE_KEYS = ("name", "package", "executable")
MANAGER_KEYS = {"node_startup_order", "wait_timeout", "transition_timeout"}
TOP_KEYS = {"nodes", "lifecycle_manager", "arguments", "robots_from"}
ARGUMENT_KEYS = {"sets", "description", "clears"}
NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
"""A ROS node name, package name or namespace token (rcl's rules, kept to the common subset)."""
TOPIC = re.compile(r"(~/|/)?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*\Z")
SCALARS = (bool, int, float, str)


class BringupError(ValueError):
    """A bringup file that cannot be used; the message names the file and the key."""


@dataclass(frozen=True)
class NodeSpec:
    """One node of a stack, as its bringup file gives it."""

    name: str
    package: str
    executable: str
    namespace: str = ""
    parameter_files: tuple[str, ...] = ()
    parameters: dict[str, object] = field(default_factory=dict)
    """Flat: nested mappings become dotted names, as ROS declares them (`lidar.beams`)."""
    remappings: tuple[tuple[str, str], ...] = ()
    per_robot: bool = False
    """A description of every robot's copy (robot_nodes), not a node itself."""

    @property
    def managed_name(self) -> str:
        """How the lifecycle manager (in the root namespace) addresses this node."""
        return f"{self.namespace}/{self.name}" if self.namespace else self.name

    def parameter_file_paths(self) -> list[Path]:
        """The parameter files as paths: absolute ones as given, others in share/<package>/config."""
        return [parameter_file_path(self.package, name) for name in self.parameter_files]

    def launch_parameters(self, directory: str | Path | None = None) -> list[str | dict[str, object]]:
        """launch_ros's `parameters=`: the files, then the inline parameters (which win), as ros_arguments.

        launch_ros takes inline only what `launch_inline_value` accepts (no empty list: the navigator's `goal: []`
        stops `ros2 launch` with "Expected 'value' to be one of [float, int, str, bool, bytes]"); the other inline
        values go, in their place between the files and the inline dict, through a parameter file written to
        `directory` (the system's temporary directory by default, as launch_ros writes its own).
        """
        entries: list[str | dict[str, object]] = [str(path) for path in self.parameter_file_paths()]
        inline = {name: value for name, value in self.parameters.items() if launch_inline_value(value)}
        refused = {name: value for name, value in self.parameters.items() if name not in inline}
        if refused:
            entries.append(str(write_parameter_file(refused, directory, prefix=f"amr_{self.name}_")))
        return entries + [inline] if inline else entries

    def ros_arguments(self) -> list[str]:
        """`--ros-args ...` giving this node its name, namespace, parameters and remappings."""
        arguments = ["--ros-args", "-r", f"__node:={self.name}"]
        if self.namespace:
            arguments += ["-r", f"__ns:={self.namespace}"]
        for path in self.parameter_file_paths():
            arguments += ["--params-file", str(path)]
        for name, value in self.parameters.items():
            arguments += ["-p", f"{name}:={yaml_scalar(value)}"]
        for source, target in self.remappings:
            arguments += ["-r", f"{source}:={target}"]
        return arguments


@dataclass(frozen=True)
class StackArgument:
    """A per-run choice: the node parameters it sets, or (params_file) the node whose files it replaces."""

    name: str
    description: str
    sets: tuple[tuple[str, str], ...] = ()
    """(node name, parameter name) pairs."""
    params_file_of: str = ""
    clears: tuple[tuple[str, str], ...] = ()
    """(node name, parameter name) pairs set to '' when the argument is given, after every argument's sets (a
    map file given: the map server's world, which another argument sets, is no longer its map)."""


@dataclass(frozen=True)
class Bringup:
    """A stack: its nodes, what the lifecycle manager is told about them, and its arguments."""

    source: Path
    nodes: tuple[NodeSpec, ...]
    node_startup_order: tuple[str, ...]
    manager_timeouts: dict[str, float] = field(default_factory=dict)
    declared_arguments: tuple[StackArgument, ...] = ()
    robots_from: tuple[str, str] | None = None
    """(node, parameter) naming the world whose robots the per_robot nodes are copied for."""

    @property
    def arguments(self) -> dict[str, StackArgument]:
        """The declared arguments, then use_sim_time and one <node>_params_file per node."""
        every = {argument.name: argument for argument in self.declared_arguments}
        every.setdefault(
            "use_sim_time",
            StackArgument(
                "use_sim_time",
                "every node on /clock time (true in simulation)",
                tuple((node.name, "use_sim_time") for node in self.nodes),
            ),
        )
        for node in self.nodes:
            name = f"{node.name}_params_file"
            every.setdefault(name, StackArgument(name, f"a parameter file replacing {node.name}'s", (), node.name))
        return every

    def current_value(self, argument: str) -> object:
        """What the stack gives an argument's first parameter now (inline, else its files), None if nothing."""
        spec = self.arguments[argument]
        node = self._node(spec.params_file_of or spec.sets[0][0])
        if spec.params_file_of:
            return ", ".join(str(path) for path in node.parameter_file_paths()) or None
        return self._value(node, spec.sets[0][1])

    @staticmethod
    def _value(node: NodeSpec, parameter: str) -> object:
        """What `node` gives `parameter` now (inline, else its files), None if nothing."""
        if parameter in node.parameters:
            return node.parameters[parameter]
        for path in reversed(node.parameter_file_paths()):
            try:
                values = dotted(node_parameters(path, node.name))
            except ValueError:
                continue
            if parameter in values:
                return values[parameter]
        return None

    def with_overrides(
        self, arguments: Mapping[str, str] | None = None, parameters: Mapping[str, str] | None = None
    ) -> Bringup:
        """This stack with `name:=value` arguments and `node.parameter:=value` parameters applied, then its
        per_robot nodes copied for the robots of its world (for_robots): the stack as it is started.

        Values are YAML, as `ros2 run -p` reads them. An unknown argument or node is refused with
        the known ones; an unknown parameter reaches the node, which refuses it at configure. A parameter
        that a declared argument sets on several nodes at once (the world: simulator and map_server) is
        refused as a -p, naming the argument to use instead.
        """
        nodes = {node.name: node for node in self.nodes}
        known = self.arguments
        for name, text in (arguments or {}).items():
            if name not in known:
                raise BringupError(f"{self.source}: unknown argument {name!r} (known: {', '.join(sorted(known))})")
            argument = known[name]
            if argument.params_file_of:
                node = nodes[argument.params_file_of]
                nodes[node.name] = replace(node, parameter_files=(str(Path(text).expanduser().resolve()),))
                continue
            for node_name, parameter in argument.sets:
                nodes[node_name] = _with_parameter(nodes[node_name], parameter, text)
        for name in arguments or {}:
            for node_name, parameter in known[name].clears:
                nodes[node_name] = _with_parameter(nodes[node_name], parameter, "")
        for dotted_name, text in (parameters or {}).items():
            node_name, dot, parameter = dotted_name.partition(".")
            if not dot or node_name not in nodes or not parameter:
                raise BringupError(
                    f"{self.source}: -p {dotted_name}: expected <node>.<parameter>:=<value> with a "
                    f"node of the stack ({', '.join(nodes)})"
                )
            tied = self.tying_argument(node_name, parameter)
            if tied is not None:
                raise BringupError(
                    f"{self.source}: -p {dotted_name}:={text}: {dotted_name} is tied to "
                    f"{', '.join(f'{n}.{q}' for n, q in tied.sets if (n, q) != (node_name, parameter))} by the stack "
                    f"argument {tied.name}:= (they must agree); give {tied.name}:={text} instead"
                )
            nodes[node_name] = _with_parameter(nodes[node_name], parameter, text)
        return replace(self, nodes=tuple(nodes[node.name] for node in self.nodes)).for_robots()

    def robots_world(self) -> str | None:
        """The world the per_robot nodes are copied for (the value of `robots_from`), None without per_robot nodes."""
        if self.robots_from is None:
            return None
        node, parameter = self.robots_from
        return str(self._value(self._node(node), parameter) or "")

    def for_robots(self) -> Bringup:
        """This stack with each per_robot node replaced by its copies for the robots of `robots_world()`."""
        if not any(node.per_robot for node in self.nodes):
            return self
        from amr_maps.world import load_world, resolve_world_path  # a fleet stack only

        world_name = self.robots_world()
        key = "robots_from"
        try:
            robots = load_world(resolve_world_path(world_name)).fleet
        except (OSError, ValueError) as error:
            raise BringupError(
                f"{self.source}: {key}: {'.'.join(self.robots_from)} = {world_name!r}: {error}"
            ) from None
        copies = {node.name: robot_nodes(node, robots) for node in self.nodes if node.per_robot}
        nodes = tuple(copy for node in self.nodes for copy in copies.get(node.name, [node]))
        order = tuple(
            name
            for entry in self.node_startup_order
            for name in ([copy.managed_name for copy in copies[entry]] if entry in copies else [entry])
        )
        return replace(self, nodes=nodes, node_startup_order=order)

    def tying_argument(self, node: str, parameter: str) -> StackArgument | None:
        """The declared argument that sets `node.parameter` together with another node's parameter, if any.

        Such a parameter (the world of a stack whose map follows the world) changes only through its argument:
        a per-node -p would run the nodes on different worlds, so it is refused naming the argument.
        """
        for argument in self.declared_arguments:
            if (node, parameter) in argument.sets and len(argument.sets) > 1:
                return argument
        return None

    def _node(self, name: str) -> NodeSpec:
        return next(node for node in self.nodes if node.name == name)

    @property
    def name(self) -> str:
        return self.source.stem

    @property
    def manager_name(self) -> str:
        """One manager per stack: two stacks in a domain must not share a node (or service) name."""
        return f"lifecycle_manager_{self.name}"

    def manager_parameters(self) -> dict[str, object]:
        """Parameters of amr_bringup.lifecycle_manager for this stack."""
        return {"node_startup_order": list(self.node_startup_order), **self.manager_timeouts}


def robot_nodes(template: NodeSpec, robots: Sequence) -> list[NodeSpec]:
    """One node per robot (amr_maps.world.RobotSpec, World.fleet order) from a per_robot description: in the
    robot's namespace under the template's own (`/r1/wall_follower`), its parameter files' values inlined (a file's
    `wall_follower:` section does not reach /r1/wall_follower; the inline parameters still win); the unnamed robot
    of a one-robot world is the template itself, in its own namespace."""
    copies = []
    for index, robot in enumerate(robots):
        if not robot.name:
            copies.append(replace(template, per_robot=False, parameters=_indexed(template.parameters, index)))
            continue
        inlined: dict[str, object] = {}
        for path in template.parameter_file_paths():
            inlined.update(dotted(node_parameters(path, template.name, BringupError)))
        inlined.update(template.parameters)
        copies.append(
            replace(
                template,
                per_robot=False,
                namespace=f"{template.namespace}/{robot.name}",
                parameter_files=(),
                parameters=_indexed(inlined, index),
            )
        )
    return copies


ROBOT_INDEX = "{robot_index}"
"""a per_robot node's parameter value replaced by the robot's index in the world's robots list."""


def _indexed(parameters: dict[str, object], index: int) -> dict[str, object]:
    return {key: index if value == ROBOT_INDEX else value for key, value in parameters.items()}


def parameter_file_path(package: str, name: str) -> Path:
    path = Path(name)
    return path if path.is_absolute() else share_directory(package, must_exist=True) / "config" / path


def shipped_bringup_dir() -> Path:
    return share_directory(BRINGUP_PACKAGE, must_exist=True) / "config" / "bringup"


def stack_summary(path: Path) -> str:
    """What a bringup file is, in a few words: its first comment up to the first colon or full stop."""
    words = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#") or line.startswith("#   "):
            break
        words.append(line.lstrip("#").strip())
    text = " ".join(words)
    for end in (": ", ". "):
        text = text.split(end)[0]
    return text.rstrip(".")


def shipped_stacks() -> dict[str, str]:
    """{name: summary} of every shipped bringup (config/bringup/*.yaml installed in share/amr_bringup)."""
    try:
        directory = shipped_bringup_dir()
    except PackageNotFoundError:
        return {}
    return {path.stem: stack_summary(path) for path in sorted(directory.glob("*.yaml"))}


def find_bringup(name_or_path: str) -> Path:
    """A path to an existing file, or the bare name of a shipped bringup (`maze_sim`)."""
    path = Path(name_or_path)
    if path.is_file():
        return path
    if os.sep not in name_or_path:
        try:
            shipped = shipped_bringup_dir()
        except PackageNotFoundError:
            raise BringupError(
                f"{name_or_path}: no such file, and package {BRINGUP_PACKAGE} is not installed (run `make setup`)"
            ) from None
        candidate = shipped / (name_or_path if name_or_path.endswith(".yaml") else f"{name_or_path}.yaml")
        if candidate.is_file():
            return candidate
        known = sorted(p.stem for p in shipped.glob("*.yaml"))
        raise BringupError(f"{name_or_path}: no such file, nor a shipped bringup (shipped: {', '.join(known)})")
    raise BringupError(f"{name_or_path}: no such file")


def load_bringup(name_or_path: str | Path) -> Bringup:
    """Read and validate a bringup file (a path, or a shipped bringup's bare name)."""
    path = find_bringup(str(name_or_path))
    try:
        document = yaml.safe_load(path.read_text(encoding="utf-8"))
    except yaml.YAMLError as error:
        raise BringupError(f"{path}: not valid YAML: {error}") from None
    return parse_bringup(document, path)


def parse_bringup(document: object, source: Path) -> Bringup:
    """Validate a parsed bringup document; every error names `source` and the key."""
    where = _Where(source)
    if not isinstance(document, dict):
        raise where.error("", f"must be a mapping with the keys {sorted(TOP_KEYS)}")
    where.no_unknown_keys("", document, TOP_KEYS)
    nodes_list = document.get("nodes")
    if not isinstance(nodes_list, list) or not nodes_list:
        raise where.error("nodes", "must be a non-empty list of nodes")
    nodes = tuple(_parse_node(where, f"nodes[{i}]", entry) for i, entry in enumerate(nodes_list))
    seen: dict[str, str] = {}
    for i, node in enumerate(nodes):
        if node.managed_name in seen:
            raise where.error(f"nodes[{i}].name", f"{node.managed_name!r} is also {seen[node.managed_name]}")
        seen[node.managed_name] = f"nodes[{i}]"
    manager = document.get("lifecycle_manager") or {}
    if not isinstance(manager, dict):
        raise where.error("lifecycle_manager", f"must be a mapping with some of the keys {sorted(MANAGER_KEYS)}")
    where.no_unknown_keys("lifecycle_manager", manager, MANAGER_KEYS)
    order = _parse_startup_order(where, manager, nodes)
    timeouts = {}
    specs = {spec.name: spec for spec in MANAGER_PARAMETERS}
    for key in ("wait_timeout", "transition_timeout"):
        if key in manager:
            try:
                timeouts[key] = specs[key].coerce(manager[key])
            except ConfigError as error:
                raise where.error(f"lifecycle_manager.{key}", str(error).removeprefix(f"{key}: ")) from None
    arguments = _parse_arguments(where, document.get("arguments") or {}, nodes)
    return Bringup(source, nodes, order, timeouts, arguments, _parse_robots_from(where, document, nodes))


def parse_assignments(words: Sequence[str], what: str) -> dict[str, str]:
    """`name:=value` words as {name: value}; BringupError for a word that is not one."""
    pairs = {}
    for word in words:
        name, sep, value = word.partition(":=")
        if not sep or not name:
            raise BringupError(f"{what} {word!r}: expected name:=value")
        pairs[name] = value
    return pairs


def check_installed(bringup: Bringup, *, executables: bool = True) -> None:
    """Every package, executable (unless composed) and parameter file the bringup names exists."""
    where = _Where(bringup.source)
    for i, node in enumerate(bringup.nodes):
        key = f"nodes[{i}]"
        try:
            prefix = package_prefix(node.package)
        except PackageNotFoundError:
            raise where.error(
                f"{key}.package",
                f"{node.name}: package {node.package!r} is not installed (not in the ament index; run `make setup`)",
            ) from None
        if executables:
            path = prefix / "lib" / node.package / node.executable
            if not (path.is_file() and os.access(path, os.X_OK)):
                raise where.error(f"{key}.executable", f"{node.name}: {path} is missing or not executable")
        for j, path in enumerate(node.parameter_file_paths()):
            if not path.is_file():
                raise where.error(f"{key}.parameter_files[{j}]", f"{node.name}: {path} does not exist")


def yaml_scalar(value: object) -> str:
    """A parameter value as the YAML that `-p name:=value` expects (1.0 stays a double)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else {math.inf: ".inf", -math.inf: "-.inf"}.get(value, ".nan")
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    return "[" + ", ".join(yaml_scalar(item) for item in value) + "]"


def launch_inline_value(value: object) -> bool:
    """A value launch_ros 0.26.6 takes in a node's inline `parameters` dict and hands on with its type.

    Its rule (launch_ros/utilities/normalize_parameters.py and evaluate_parameters.py): bool, int, float, str,
    bytes, or a non-empty list whose items are all of one of bool, int, float, str (launch_ros would turn a list
    mixing ints and floats into floats, and refuses every other mix, an empty list and a nested one). Non-finite
    floats are kept out too: they reach the node through a file, as YAML's .inf/.nan.
    """
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, (bool, int, str, bytes)):
        return True
    if not isinstance(value, (list, tuple)) or not value:
        return False
    kind = type(value[0])
    return kind in (bool, int, float, str) and all(type(item) is kind and launch_inline_value(item) for item in value)


def write_parameter_file(
    parameters: Mapping[str, object], directory: str | Path | None = None, *, prefix: str = "amr_params_"
) -> Path:
    """`parameters` (flat, dotted names) in a new ROS 2 parameter file for any node (`/**: ros__parameters:`),
    nested as ROS reads dotted names; lists mixing ints and floats as floats (rcl refuses a mixed list)."""
    nested: dict[str, object] = {}
    for name, value in parameters.items():
        *groups, last = name.split(".")
        level = nested
        for group in groups:
            level = level.setdefault(group, {})
        if (
            isinstance(value, (list, tuple))
            and value
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
        ):
            value = [float(v) for v in value] if any(isinstance(v, float) for v in value) else list(value)
        level[last] = list(value) if isinstance(value, tuple) else value
    handle, name = tempfile.mkstemp(prefix=prefix, suffix=".yaml", dir=directory)
    with os.fdopen(handle, "w", encoding="utf-8") as stream:
        yaml.safe_dump({"/**": {"ros__parameters": nested}}, stream, default_flow_style=None)
    return Path(name)


# -- parsing helpers ----------------------------------------------------------------------------


class _Where:
    """Builds errors that say `<file>: <key>: <problem>`."""

    def __init__(self, source: Path) -> None:
        self.source = source

    def error(self, key: str, problem: str) -> BringupError:
        return BringupError(f"{self.source}: {key + ': ' if key else ''}{problem}")

    def no_unknown_keys(self, key: str, mapping: dict, allowed: set[str]) -> None:
        unknown = sorted(str(k) for k in set(mapping) - allowed)
        if unknown:
            raise self.error(key, f"unknown key(s) {unknown}; allowed: {sorted(allowed)}")


def _parse_node(where: _Where, key: str, entry: object) -> NodeSpec:
    if not isinstance(entry, dict):
        raise where.error(key, f"must be a mapping with the keys {list(REQUIRED_NODE_KEYS)} at least")
    where.no_unknown_keys(key, entry, NODE_KEYS)
    for required in REQUIRED_NODE_KEYS:
        value = entry.get(required)
        if not isinstance(value, str) or not NAME.match(value):
            raise where.error(f"{key}.{required}", f"must be a name of letters, digits and _, got {value!r}")
    namespace = entry.get("namespace") or ""
    tokens = namespace.strip("/").split("/") if isinstance(namespace, str) and namespace.strip("/") else []
    if not isinstance(namespace, str) or not all(NAME.match(token) for token in tokens):
        raise where.error(
            f"{key}.namespace", f"must be a ROS namespace such as robot1 or /fleet/robot1, got {namespace!r}"
        )
    files = entry.get("parameter_files", [])
    if not isinstance(files, list) or not all(isinstance(f, str) and f for f in files):
        raise where.error(f"{key}.parameter_files", f"must be a list of file names, got {files!r}")
    parameters = entry.get("parameters", {})
    if not isinstance(parameters, dict):
        raise where.error(f"{key}.parameters", f"must be a mapping of parameter names to values, got {parameters!r}")
    remappings = entry.get("remappings", {})
    if not isinstance(remappings, dict):
        raise where.error(f"{key}.remappings", f"must be a mapping from: to, got {remappings!r}")
    for source, target in remappings.items():
        for name in (source, target):
            if not isinstance(name, str) or not TOPIC.match(name):
                raise where.error(f"{key}.remappings", f"{name!r} is not a topic or service name")
    per_robot = entry.get("per_robot", False)
    if not isinstance(per_robot, bool):
        raise where.error(f"{key}.per_robot", f"must be true or false, got {per_robot!r}")
    return NodeSpec(
        name=entry["name"],
        package=entry["package"],
        executable=entry["executable"],
        namespace="/" + "/".join(tokens) if tokens else "",
        parameter_files=tuple(files),
        parameters=_flat_parameters(where, f"{key}.parameters", parameters),
        remappings=tuple(remappings.items()),
        per_robot=per_robot,
    )


def _parse_robots_from(where: _Where, document: dict, nodes: tuple[NodeSpec, ...]) -> tuple[str, str] | None:
    """`robots_from: <node>.<parameter>`: required with a per_robot node, refused without one."""
    value = document.get("robots_from")
    templates = [node.name for node in nodes if node.per_robot]
    if value is None:
        if templates:
            raise where.error(
                "robots_from",
                f"required with per_robot nodes ({', '.join(templates)}): the "
                "<node>.<parameter> naming the world whose robots they serve",
            )
        return None
    if not templates:
        raise where.error("robots_from", "no node has per_robot: true")
    node, dot, parameter = str(value).partition(".")
    fixed = {n.name for n in nodes if not n.per_robot}
    if not dot or node not in fixed or not parameter:
        raise where.error("robots_from", f"{value!r} is not <node>.<parameter> of a node in {sorted(fixed)}")
    return node, parameter


def _flat_parameters(where: _Where, key: str, parameters: Mapping, prefix: str = "") -> dict[str, object]:
    flat: dict[str, object] = {}
    for name, value in parameters.items():
        full = f"{prefix}{name}"
        if not isinstance(name, str) or not NAME.match(name):
            raise where.error(key, f"{full!r} is not a parameter name")
        if isinstance(value, dict):
            flat.update(_flat_parameters(where, key, value, f"{full}."))
        elif isinstance(value, SCALARS):
            flat[full] = value
        elif isinstance(value, list):
            kinds = {type(item) for item in value}
            if not value or len(kinds) != 1 or not kinds <= set(SCALARS):
                raise where.error(
                    f"{key}.{full}",
                    f"a list parameter needs items of one type (bool, int, float "
                    f"or string; write 1.0 for a float), got {value!r}",
                )
            flat[full] = list(value)
        else:
            raise where.error(f"{key}.{full}", f"unsupported value {value!r}")
    return flat


def _parse_arguments(where: _Where, arguments: object, nodes: tuple[NodeSpec, ...]) -> tuple[StackArgument, ...]:
    if not isinstance(arguments, dict):
        raise where.error("arguments", "must be a mapping of argument names to {sets, description}")
    names = {node.name for node in nodes}
    parsed = []
    for name, entry in arguments.items():
        key = f"arguments.{name}"
        if not isinstance(name, str) or not NAME.match(name):
            raise where.error("arguments", f"{name!r} is not an argument name")
        if not isinstance(entry, dict):
            raise where.error(key, "must be a mapping with the keys sets and description")
        where.no_unknown_keys(key, entry, ARGUMENT_KEYS)
        sets = entry.get("sets")
        if not isinstance(sets, list) or not sets:
            raise where.error(f"{key}.sets", f"must be a non-empty list of <node>.<parameter>, got {sets!r}")
        clears = entry.get("clears", [])
        if not isinstance(clears, list):
            raise where.error(f"{key}.clears", f"must be a list of <node>.<parameter>, got {clears!r}")
        targets: dict[str, list[tuple[str, str]]] = {"sets": [], "clears": []}
        for field_name, listed in (("sets", sets), ("clears", clears)):
            for target in listed:
                node, dot, parameter = str(target).partition(".")
                if not dot or node not in names or not parameter:
                    raise where.error(
                        f"{key}.{field_name}", f"{target!r} is not <node>.<parameter> of a node in {sorted(names)}"
                    )
                targets[field_name].append((node, parameter))
        parsed.append(
            StackArgument(
                name, str(entry.get("description", "")), tuple(targets["sets"]), clears=tuple(targets["clears"])
            )
        )
    return tuple(parsed)


def _with_parameter(node: NodeSpec, parameter: str, text: str) -> NodeSpec:
    """`node` with one inline parameter set from its YAML text; an empty list means: as the files say."""
    try:
        value = yaml.safe_load(text) if text != "" else ""
    except yaml.YAMLError as error:
        raise BringupError(f"{node.name}.{parameter}:={text}: not a YAML value ({error})") from None
    parameters = dict(node.parameters)
    if value == []:
        parameters.pop(parameter, None)
    else:
        head, *nested = parameter.split(".")  # a dotted name: a nested section (traffic_rules.wait_time)
        for part in reversed(nested):
            value = {part: value}
        flat = _flat_parameters(_Where(Path("command line")), node.name, {head: value})
        parameters.update(flat)
    return replace(node, parameters=parameters)


def _parse_startup_order(where: _Where, manager: dict, nodes: tuple[NodeSpec, ...]) -> tuple[str, ...]:
    names = [node.managed_name for node in nodes]
    order = manager.get("node_startup_order", names)
    key = "lifecycle_manager.node_startup_order"
    if not isinstance(order, list) or not order or not all(isinstance(n, str) for n in order):
        raise where.error(key, f"must be a non-empty list of node names, got {order!r}")
    for name in order:
        if name not in names:
            raise where.error(key, f"{name!r} is not one of the nodes {names}")
    if len(set(order)) != len(order):
        raise where.error(key, f"names a node twice: {order}")
    return tuple(order)
