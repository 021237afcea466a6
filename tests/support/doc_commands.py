"""The commands the docs show, found and checked without running them (helpers of test_docs.py).

Every fenced `bash`/`sh`/`console` block of README.md, docs/*.md and bench/README.md, and every
inline code span that starts like a command, is split into commands. Each is checked against what
it names, with the parsers the tools themselves use where there is one: amr-bringup's argument
parser and its stack loader, the node's parameter specs for every `-p name:=value` and parameter
file, the installed launchers, launch files, console scripts, Makefile targets, interface types
and their fields, scripts and their flags. A command the checker does not know fails, so a new kind
of command in the docs needs a check here.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import re
import shlex
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import yaml

from amr_util.parameter_file import dotted
from amr_util.parameter_spec import ConfigError

from .scripts import load_script

ROOT = Path(__file__).resolve().parents[2]


parameter_docs = load_script("parameter_docs")
"""scripts/parameter_docs.py: which specs each node has (the registry that writes the docs' tables)."""

DOC_FILES = sorted([ROOT / "README.md", ROOT / "bench" / "README.md", *(ROOT / "docs").glob("*.md")])
SHELL_BLOCKS = {"bash", "sh", "shell", "console"}
INLINE_STARTS = (
    "amr-bringup ",
    ".venv/bin/",
    ".venv/lib/",
    "ros2 run ",
    "ros2 launch ",
    "ros2 param ",
    "make ",
    "python ",
    "ros2 service call ",
    "amr-render-bag ",
)
ALWAYS_KNOWN = {"use_sim_time", "autostart"}
PLACEHOLDERS = ("<", "...", "path/to", "my_", "/path/")
ACCEPTED = {  # commands whose effect needs a ROS graph or another machine: their words are not checked
    ("ros2", "node"),
    ("ros2", "topic"),
    ("ros2", "pkg"),
    ("ros2", "doctor"),
    ("ros2", "bag"),
    ("ros2", "lifecycle"),
    ("cd",),
    ("git",),
    ("source",),
    ("rviz2",),
    ("rosdep",),
    ("pip",),
    ("dask",),
}


@dataclass(frozen=True)
class Command:
    words: tuple[str, ...]
    where: str
    """file:line, for the failure message."""

    def __str__(self) -> str:
        return f"{self.where}: {shlex.join(self.words)}"


def code_blocks(text: str) -> Iterator[tuple[str, str, int]]:
    """(language, body, line of the body's first line) of every fenced block."""
    for match in re.finditer(r"^```(\w*)\n(.*?)^```", text, re.S | re.M):
        yield match[1], match[2], text.count("\n", 0, match.start(2)) + 1


def shell_lines(language: str, body: str) -> Iterator[tuple[int, str]]:
    """(offset, command line) of a shell block: `$ ` lines of a console block, every line of a bash one."""
    lines = body.split("\n")
    joined: list[tuple[int, str]] = []
    for i, line in enumerate(lines):
        if language == "console":
            if line.startswith("$ "):
                joined.append((i, line[2:]))
        elif joined and joined[-1][1].endswith("\\"):
            joined[-1] = (joined[-1][0], joined[-1][1][:-1] + " " + line.strip())
        elif line.strip() and not line.lstrip().startswith("#"):
            joined.append((i, line.strip()))
    return iter(joined)


def split_commands(line: str) -> list[list[str]]:
    """The commands of one shell line: split at `&&`, `;` and `|` (only the first command of a pipe is ours)."""
    words = shlex.split(line, comments=True)
    commands, current, piped = [], [], False
    for word in words:
        if word in ("&&", ";", "|"):
            if current and not piped:
                commands.append(current)
            current, piped = [], word == "|"
        else:
            current.append(word)
    if current and not piped:
        commands.append(current)
    return commands


def doc_commands(path: Path) -> list[Command]:
    """Every command of one docs file."""
    text = path.read_text(encoding="utf-8")
    name = path.relative_to(ROOT)
    found = []
    for language, body, first in code_blocks(text):
        if language in SHELL_BLOCKS:
            for offset, line in shell_lines(language, body):
                found += [Command(tuple(words), f"{name}:{first + offset}") for words in split_commands(line)]
    prose = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    for match in re.finditer(r"`([^`\n]+)`", prose):
        span = match[1]
        if span.startswith(INLINE_STARTS) and not is_placeholder(span):
            line = text.count("\n", 0, text.find(match[0])) + 1
            found += [Command(tuple(words), f"{name}:{line}") for words in split_commands(span) if complete(words)]
    return found


def complete(words: list[str]) -> bool:
    """Whether an inline span is a whole command (`ros2 run amr_maps map_server`), not a fragment of
    one the prose talks about (`ros2 run -p`, `amr-bringup --record`)."""
    need = 4 if words[0] == "ros2" else 2
    return len(words) >= need and not any(word.startswith("-") for word in words[1:need])


def all_commands() -> list[Command]:
    return [command for path in DOC_FILES for command in doc_commands(path)]


# -- what the commands may name -----------------------------------------------------------------


def is_placeholder(text: str) -> bool:
    return any(mark in text for mark in PLACEHOLDERS)


def node_specs(package: str, executable: str) -> dict:
    """{name: spec} of a node's parameters, from the registry that writes the docs' tables."""
    for node in parameter_docs.NODES:
        if (node.package, node.executable) == (package, executable):
            return {spec.name: spec for spec in node.specs()}
    raise AssertionError(f"{package}/{executable}: no node with parameter specs (scripts/parameter_docs.py)")


def check_parameter(package: str, executable: str, name: str, value: object) -> None:
    """A known parameter of the node, and a value its spec takes (placeholders pass)."""
    if name in ALWAYS_KNOWN or name.startswith("qos_overrides."):
        return
    specs = node_specs(package, executable)
    if executable == "ik_service" and "." in name:
        from amr_kinematics.config import CHAIN_KEYS

        key = name.partition(".")[2]
        assert key in CHAIN_KEYS, f"{name}: not a chain key of ik_service"
        spec = dataclasses.replace(CHAIN_KEYS[key], name=name, integers_as_floats=True)
    else:
        assert name in specs, f"{name}: not a parameter of {package}/{executable} (known: {', '.join(sorted(specs))})"
        spec = specs[name]
    if isinstance(value, str) and is_placeholder(value):
        return
    try:
        spec.coerce(value)
    except ConfigError as error:
        raise AssertionError(f"{package}/{executable}: {error}") from None


def check_parameter_file(package: str, executable: str, path: Path, section: str) -> None:
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    assert isinstance(data, dict) and section in data, f"{path}: no '{section}:' section"
    for name, value in dotted(data[section]["ros__parameters"]).items():
        check_parameter(package, executable, name, value)


def check_ros_args(package: str, executable: str, words: list[str]) -> None:
    """`--ros-args -p name:=value --params-file file -r from:=to ...` of one node."""
    if not words:
        return
    assert words[0] == "--ros-args", f"expected --ros-args, got {words[0]!r}"
    rest = iter(words[1:])
    for word in rest:
        if word == "-p":
            assignment = next(rest)
            name, sep, text = assignment.partition(":=")
            assert sep and name, f"-p {assignment}: expected name:=value (quote a value with spaces)"
            try:
                value = yaml.safe_load(text)
            except yaml.YAMLError as error:
                raise AssertionError(f"-p {assignment}: not a YAML value ({error}); quote it") from None
            check_parameter(package, executable, name, value)
        elif word == "--params-file":
            path = ROOT / next(rest)
            assert path.is_file(), f"--params-file {path}: no such file"
            section = executable
            check_parameter_file(package, executable, path, section)
        elif word == "-r":
            next(rest)
        else:
            raise AssertionError(f"{word!r}: not a ROS argument this checker knows")


def console_scripts() -> dict[str, str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    return project["scripts"]


def check_flags(words: list[str], source: str, what: str) -> None:
    for word in words:
        if word.startswith("--"):
            flag = word.split("=")[0]
            assert flag in source, f"{what} has no option {flag}"


def check_bringup(words: list[str]) -> None:
    from amr_bringup.bringup import parse_arguments
    from amr_bringup.stack_config import load_bringup, parse_assignments

    try:
        options = parse_arguments(words)
    except SystemExit as exit:
        assert exit.code == 0, f"amr-bringup refused {shlex.join(words)}"
        return
    if is_placeholder(options.bringup):
        return
    stack = load_bringup(options.bringup)
    if options.show_args:
        return
    arguments = {
        name: value
        for name, value in parse_assignments(options.arguments, "argument").items()
        if not is_placeholder(value)
    }
    bringup = stack.with_overrides(arguments, parse_assignments(options.parameters, "-p"))
    for node in bringup.nodes:
        for name, value in node.parameters.items():
            check_parameter(node.package, node.executable, name, value)


def check_service_call(words: list[str]) -> None:
    service, type_name, request = words[:3]
    package, kind, name = type_name.split("/")
    assert kind == "srv", f"{type_name}: not a service type"
    request_class = getattr(importlib.import_module(f"{package}.srv"), name).Request
    check_fields(request_class, yaml.safe_load(request), type_name)


def check_fields(message_class, values: dict, where: str) -> None:
    fields = message_class.get_fields_and_field_types()
    for key, value in values.items():
        assert key in fields, f"{where}: no field {key!r} (fields: {', '.join(fields)})"
        if isinstance(value, dict):
            field_type = fields[key]
            package, name = field_type.split("/")
            nested = getattr(importlib.import_module(f"{package}.msg"), name)
            check_fields(nested, value, f"{where}.{key}")


def launcher_module(package: str, executable: str) -> str:
    """The module an installed launcher (resource/lib/<package>/<executable>) runs."""
    launcher = ROOT / "resource" / "lib" / package / executable
    assert launcher.is_file(), f"{package}/{executable}: no such executable (resource/lib)"
    return re.search(r"-m ([\w.]+)", launcher.read_text(encoding="utf-8"))[1]


def module_source(module: str) -> str:
    return Path(importlib.util.find_spec(module).origin).read_text(encoding="utf-8")


def is_node(package: str, executable: str) -> bool:
    """A launcher of a ROS node (its module uses rclpy), not of a command-line tool such as amr-maze."""
    return "rclpy" in module_source(launcher_module(package, executable))


def check_node_command(package: str, executable: str, words: list[str]) -> None:
    if is_node(package, executable):
        check_ros_args(package, executable, words)
    else:
        check_flags(words, module_source(launcher_module(package, executable)), f"{package}/{executable}")


def check(command: Command) -> None:
    """AssertionError naming what is wrong with one documented command."""
    words = list(command.words)
    head = words[0]
    if head.startswith(".venv/bin/") and head != ".venv/bin/python":
        head = words[0] = head.removeprefix(".venv/bin/")
    if tuple(words[:2]) in ACCEPTED or (head,) in ACCEPTED:
        return
    if head == "make":
        makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
        targets = set(re.findall(r"^([\w-]+):", makefile, re.M))
        variables = {word.partition("=")[0] for word in words[1:] if "=" in word}  # make test TEST_WORKERS=2
        assert {word for word in words[1:] if "=" not in word} <= targets, f"make {' '.join(words[1:])}: no such target"
        unused = [name for name in sorted(variables) if f"$({name})" not in makefile]
        assert not unused, f"make {' '.join(words[1:])}: the Makefile reads no {', '.join(unused)}"
    elif head == "amr-bringup":
        check_bringup(words[1:])
    elif head in ("python", "python3", ".venv/bin/python"):
        if words[1] == "-m":
            assert importlib.util.find_spec(words[2]) is not None, f"python -m {words[2]}: no such module"
            if words[2] == "amr_bringup.bringup" and words[3:]:
                check_bringup(words[3:])
        else:
            script = ROOT / words[1]
            assert script.is_file(), f"{words[1]}: no such script"
            check_flags(words[2:], script.read_text(encoding="utf-8"), words[1])
    elif head in console_scripts():
        check_flags(words[1:], module_source(console_scripts()[head].split(":")[0]), head)
    elif head.startswith(".venv/lib/"):
        package, executable = head.removeprefix(".venv/lib/").split("/")
        check_node_command(package, executable, words[1:])
    elif head == "ros2" and words[1] == "run":
        check_node_command(words[2], words[3], words[4:])
    elif head == "ros2" and words[1] == "launch":
        package, launch_file = words[2], words[3]
        assert package == "amr_bringup" and (ROOT / "launch" / launch_file).is_file(), (
            f"{package} {launch_file}: no such launch file"
        )
        from amr_bringup.stack_config import load_bringup, parse_assignments

        arguments = [word for word in words[4:] if word != "--show-args"]
        stack = load_bringup(launch_file.removesuffix(".launch.py"))
        stack.with_overrides(
            {
                name: value
                for name, value in parse_assignments(arguments, "argument").items()
                if not is_placeholder(value)
            }
        )
    elif head == "ros2" and words[1] == "service" and words[2] == "call":
        check_service_call(words[3:])
    elif head == "ros2" and words[1] == "param":
        verb, node = words[2], words[3].rsplit("/", 1)[-1]
        package = next(n.package for n in parameter_docs.NODES if n.executable == node)
        if verb == "set":
            check_parameter(package, node, words[4], yaml.safe_load(words[5]))
        else:
            for name in words[4:]:
                assert name in node_specs(package, node) or name in ALWAYS_KNOWN, f"{name}: not a parameter of {node}"
    elif head == "colcon":
        assert "amr_interfaces" in " ".join(words), "colcon must be given amr_interfaces' base path too"
    else:
        raise AssertionError(f"{head}: a command the doc checker does not know (tests/support/doc_commands.py)")
