"""The ROS launch files, checked without launch installed: the LaunchDescription builder they share
(amr_bringup/launch_builder.py) against launch_ros's Jazzy API, and that everything each file starts
(through its bringup file) exists in the install layout.

The keyword sets are those of launch_ros 0.26.6 (Jazzy) actions/node.py and lifecycle_node.py and of
launch 3.4.3 actions/execute_process.py and execute_local.py, where Node's **kwargs end up.
"""

import ast
import math
import sys
from pathlib import Path

import pytest

from amr_bringup.stack_config import check_installed, load_bringup

ROOT = Path(__file__).resolve().parents[2]
PREFIX = Path(sys.prefix)
LAUNCH_FILES = sorted((ROOT / "launch").glob("*.launch.py"))
BUILDER = ROOT / "amr_bringup" / "launch_builder.py"

EXECUTE_PROCESS_KEYWORDS = {"prefix", "cwd", "env", "additional_env"}  # launch 3.4.3 ExecuteProcess
EXECUTE_LOCAL_KEYWORDS = {
    "shell",
    "sigterm_timeout",
    "sigkill_timeout",
    "emulate_tty",
    "output",
    "output_format",
    "cached_output",
    "log_cmd",
    "on_exit",
    "respawn",
    "respawn_delay",
    "respawn_max_retries",
}
NODE_KEYWORDS = (
    {
        "executable",
        "package",
        "name",
        "namespace",
        "exec_name",
        "parameters",
        "remappings",
        "ros_arguments",
        "arguments",
    }
    | EXECUTE_PROCESS_KEYWORDS
    | EXECUTE_LOCAL_KEYWORDS
)
REQUIRED = {"LifecycleNode": {"name", "namespace", "executable"}, "Node": {"executable"}}
ARGUMENT_KEYWORDS = {"default_value", "description", "choices"}  # launch 3.4.3 DeclareLaunchArgument
OPAQUE_KEYWORDS = {"function", "args", "kwargs"}  # launch 3.4.3 OpaqueFunction
KNOWN_IMPORTS = {
    "launch": {"LaunchDescription"},
    "launch.actions": {"DeclareLaunchArgument", "OpaqueFunction"},
    "launch_ros.actions": {"LifecycleNode", "Node"},
    "amr_bringup.stack_config": {"load_bringup"},
    "amr_bringup.launch_builder": {"launch_description"},
}


def parsed(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def calls(tree: ast.Module, name: str) -> list[ast.Call]:
    return [
        node
        for node in ast.walk(tree)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == name
    ]


def bringup_name(tree: ast.Module) -> str:
    (value,) = [
        node.value.value
        for node in tree.body
        if isinstance(node, ast.Assign) and [t.id for t in node.targets if isinstance(t, ast.Name)] == ["BRINGUP"]
    ]
    return value


def test_one_launch_file_per_shipped_bringup():
    shipped = sorted(path.stem for path in (ROOT / "config" / "bringup").glob("*.yaml"))
    assert [path.name.removesuffix(".launch.py") for path in LAUNCH_FILES] == shipped


def imports(tree: ast.Module, where: str) -> dict[str, set[str]]:
    imported: dict[str, set[str]] = {}
    for node in ast.walk(tree):
        assert not isinstance(node, ast.Import), f"{where}: plain import {ast.unparse(node)}"
        if isinstance(node, ast.ImportFrom):
            imported.setdefault(node.module, set()).update(alias.name for alias in node.names)
    for module, names in imported.items():
        assert module in KNOWN_IMPORTS and names <= KNOWN_IMPORTS[module], f"{where}: from {module} import {names}"
    return imported


@pytest.mark.parametrize("path", LAUNCH_FILES, ids=lambda p: p.name)
def test_launch_file_builds_its_bringup_with_the_shared_builder(path):
    tree = parsed(path)
    assert imports(tree, path.name) == {"amr_bringup.launch_builder": {"launch_description"}}
    (function,) = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "generate_launch_description"]
    assert not function.args.args
    (returned,) = [n.value for n in ast.walk(function) if isinstance(n, ast.Return)]
    assert ast.unparse(returned) == "launch_description(BRINGUP)"


def test_builder_imports_only_known_launch_names_and_returns_a_launch_description():
    tree = parsed(BUILDER)
    assert imports(tree, BUILDER.name).keys() >= {"launch", "launch_ros.actions"}
    (function,) = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "launch_description"]
    returned = [n.value for n in ast.walk(function) if isinstance(n, ast.Return)]
    assert len(returned) == 1 and isinstance(returned[0], ast.Call) and returned[0].func.id == "LaunchDescription"


def test_arguments_are_declared_and_the_nodes_made_when_the_launch_runs():
    tree = parsed(BUILDER)
    (declare,) = calls(tree, "DeclareLaunchArgument")
    assert len(declare.args) == 1 and {k.arg for k in declare.keywords} <= ARGUMENT_KEYWORDS
    (opaque,) = calls(tree, "OpaqueFunction")
    assert not opaque.args and {k.arg for k in opaque.keywords} <= OPAQUE_KEYWORDS
    function = {k.arg: k.value for k in opaque.keywords}["function"].id
    (actions,) = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == function]
    assert [a.arg for a in actions.args.args][0] == "context", "OpaqueFunction calls function(context, *args)"
    assert "with_overrides" in ast.unparse(actions), "the same overrides as amr-bringup"


def test_launch_actions_use_launch_ros_keywords_only():
    tree = parsed(BUILDER)
    for action, required in REQUIRED.items():
        found = calls(tree, action)
        assert found, f"{BUILDER.name} has no {action}"
        for call in found:
            assert not call.args, f"{action} takes keyword arguments only"
            keywords = {k.arg for k in call.keywords}
            assert None not in keywords, f"**kwargs hides what {action} receives"
            assert keywords <= NODE_KEYWORDS, f"{action} gets unknown {keywords - NODE_KEYWORDS}"
            assert required <= keywords, f"{action} lacks {required - keywords}"
    (manager,) = calls(tree, "Node")
    given = {k.arg: k.value for k in manager.keywords}
    assert ast.literal_eval(given["package"]) == "amr_bringup"
    assert ast.literal_eval(given["executable"]) == "lifecycle_manager"
    assert (PREFIX / "lib" / "amr_bringup" / "lifecycle_manager").is_file()


@pytest.mark.parametrize("path", LAUNCH_FILES, ids=lambda p: p.name)
def test_what_the_launch_file_starts_exists_in_the_install_layout(path):
    name = bringup_name(parsed(path))
    assert path.name == f"{name}.launch.py"
    assert (PREFIX / "share" / "amr_bringup" / "launch" / path.name).read_text() == path.read_text()
    check_installed(load_bringup(name))  # packages, lib/<package>/<executable>, parameter files


def launch_ros_value(value) -> bool:
    """A value launch_ros's normalize_parameter_dict takes and writes back with its type."""
    if isinstance(value, (bool, int, str)) or (isinstance(value, float) and math.isfinite(value)):
        return True
    return (
        isinstance(value, list)
        and len(value) > 0
        and len({type(v) for v in value}) == 1
        and all(launch_ros_value(v) for v in value)
    )


@pytest.mark.parametrize("path", LAUNCH_FILES, ids=lambda p: p.name)
def test_values_handed_to_launch_ros_have_the_types_it_accepts(path):
    bringup = load_bringup(bringup_name(parsed(path)))
    for node in bringup.nodes:
        parameters = node.launch_parameters()
        assert type(parameters) is list  # Node(parameters=...) is checked with ensure_argument_type(.., list)
        for entry in parameters:
            if isinstance(entry, str):
                assert Path(entry).is_absolute() and Path(entry).is_file()
            else:
                assert all(launch_ros_value(v) for v in entry.values()), entry
        assert all(len(rule) == 2 and all(isinstance(s, str) for s in rule) for rule in node.remappings)
        assert isinstance(node.namespace, str)
    assert all(launch_ros_value(v) for v in bringup.manager_parameters().values())
