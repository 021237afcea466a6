"""Every shipped stack's launch description, built by the real builder (amr_bringup/launch_builder.py) over
stand-ins for launch and launch_ros (not installed here), holds only values launch_ros 0.26.6 accepts.

The rule is launch_ros's own (launch_ros/utilities/normalize_parameters.py, evaluate_parameters.py), written out
here without importing it: an inline parameter value is a bool, int, float, str or bytes, or a non-empty list whose
items are all of one type among bool, int, float, str. `ros2 launch amr_bringup fleet_navigation.launch.py
world:=fleets/crossing.yaml` stopped at the navigators' `goal: []` ("Expected 'value' to be one of [float, int,
str, bool, bytes], but got '()'"); such values now reach the node through a parameter file.
"""

import importlib
import math
import sys
import types
from pathlib import Path

import pytest
import yaml

from amr_bringup.stack_config import launch_inline_value, load_bringup, write_parameter_file

ROOT = Path(__file__).resolve().parents[2]
LAUNCH_FILES = sorted((ROOT / "launch").glob("*.launch.py"))
STACKS = sorted(path.stem for path in (ROOT / "config" / "bringup").glob("*.yaml"))
FLEET_WORLDS = [f"fleets/{path.name}" for path in sorted((ROOT / "config" / "worlds" / "fleets").glob("*.yaml"))]
ONE_ROBOT_WORLD = "inner_maze.yaml"  # a world without a robots list: one copy in the root namespace


def accepted_by_launch_ros(value) -> bool:
    """launch_ros 0.26.6's rule for a value in a node's inline `parameters` dict (module docstring)."""
    if type(value) in (bool, int, float, str, bytes):
        return not (isinstance(value, float) and not math.isfinite(value))
    if isinstance(value, (list, tuple)) and len(value) > 0:
        kind = type(value[0])
        return kind in (bool, int, float, str) and all(type(item) is kind for item in value)
    return False


class Recorded:
    """A launch or launch_ros class: remembers what it was made with."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


@pytest.fixture
def builder(monkeypatch, tmp_path):
    """amr_bringup.launch_builder imported over stand-in launch/launch_ros modules; temp files in tmp_path."""
    modules = {}
    for module, names in {
        "launch": ["LaunchDescription"],
        "launch.actions": ["DeclareLaunchArgument", "OpaqueFunction"],
        "launch_ros": [],
        "launch_ros.actions": ["LifecycleNode", "Node"],
    }.items():
        modules[module] = types.ModuleType(module)
        for name in names:
            setattr(modules[module], name, type(name, (Recorded,), {}))
        monkeypatch.setitem(sys.modules, module, modules[module])
    monkeypatch.delitem(sys.modules, "amr_bringup.launch_builder", raising=False)
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    yield importlib.import_module("amr_bringup.launch_builder")
    sys.modules.pop("amr_bringup.launch_builder", None)


def launched_actions(builder, stack: str, given: dict[str, str]) -> list[Recorded]:
    """What `ros2 launch amr_bringup <stack>.launch.py name:=value ...` starts: the OpaqueFunction run."""
    description = builder.launch_description(stack)
    (entries,) = description.args
    (opaque,) = [entry for entry in entries if type(entry).__name__ == "OpaqueFunction"]
    declared = {entry.args[0] for entry in entries if type(entry).__name__ == "DeclareLaunchArgument"}
    assert set(given) <= declared
    context = types.SimpleNamespace(launch_configurations={name: "" for name in declared} | given)
    return opaque.kwargs["function"](context, *opaque.kwargs["args"])


def cases() -> list[tuple[str, dict[str, str]]]:
    every = []
    for stack in STACKS:
        every.append((stack, {}))
        if load_bringup(stack).robots_from is not None:
            every += [(stack, {"world": world}) for world in [*FLEET_WORLDS, ONE_ROBOT_WORLD]]
    return every


def test_every_launch_file_has_its_stack_here():
    assert [path.name.removesuffix(".launch.py") for path in LAUNCH_FILES] == STACKS


@pytest.mark.parametrize(
    ("stack", "given"), cases(), ids=lambda c: c if isinstance(c, str) else str(c.get("world", ""))
)
def test_every_value_handed_to_launch_ros_is_one_it_accepts(builder, stack, given):
    actions = launched_actions(builder, stack, given)
    nodes = [action for action in actions if type(action).__name__ == "LifecycleNode"]
    assert nodes and sum(type(action).__name__ == "Node" for action in actions) == 1
    if given.get("world", "").startswith("fleets/"):
        assert any(node.kwargs["namespace"] for node in nodes), "a fleet world's robots are in their namespaces"
    for action in actions:
        parameters = action.kwargs["parameters"]
        assert type(parameters) is list
        for entry in parameters:
            if isinstance(entry, str):
                path = Path(entry)
                assert path.is_absolute() and path.is_file(), entry
                document = yaml.safe_load(path.read_text())
                assert isinstance(document, dict) and all("ros__parameters" in v for v in document.values()), entry
            else:
                refused = {name: value for name, value in entry.items() if not accepted_by_launch_ros(value)}
                assert not refused, (
                    f"{stack} {given}: {action.kwargs.get('namespace')}/{action.kwargs['name']}: "
                    f"launch_ros refuses {refused}"
                )


def test_the_fleet_navigators_goal_reaches_them_through_a_file(builder):
    actions = launched_actions(builder, "fleet_navigation", {"world": "fleets/crossing.yaml"})
    navigators = [a for a in actions if a.kwargs["name"] == "navigator"]
    assert len(navigators) >= 2
    for navigator in navigators:
        files = [Path(entry) for entry in navigator.kwargs["parameters"] if isinstance(entry, str)]
        inline = [entry for entry in navigator.kwargs["parameters"] if isinstance(entry, dict)]
        (written,) = [
            yaml.safe_load(path.read_text())
            for path in files
            if path.parent == Path(sys.modules["tempfile"].gettempdir())
        ]
        assert written == {"/**": {"ros__parameters": {"goal": []}}}
        assert inline and "goal" not in inline[0] and inline[0]["traffic"] is True


@pytest.mark.parametrize(
    ("value", "accepted"),
    [
        (1, True),
        (1.5, True),
        (True, True),
        ("", True),
        (b"x", True),
        ([1, 2], True),
        (["a"], True),
        ([True], True),
        ([], False),
        ([1, 2.5], False),
        (["a", 1], False),
        ([[1.0, 2.0]], False),
        ({"a": 1}, False),
        (None, False),
        (math.nan, False),
        ([True, 1], False),
    ],
)
def test_the_suite_s_rule_is_launch_ros_s(value, accepted):
    assert launch_inline_value(value) is accepted
    assert accepted_by_launch_ros(value) is accepted


def test_the_parameter_file_nests_dotted_names_and_keeps_types(tmp_path):
    path = write_parameter_file({"goal": [], "costmap.robot_radius": 0.1, "window": [1, 2.5], "ids": [1, 2]}, tmp_path)
    assert path.parent == tmp_path
    assert yaml.safe_load(path.read_text()) == {
        "/**": {"ros__parameters": {"goal": [], "costmap": {"robot_radius": 0.1}, "window": [1.0, 2.5], "ids": [1, 2]}}
    }
    assert isinstance(yaml.safe_load(path.read_text())["/**"]["ros__parameters"]["window"][0], float)
