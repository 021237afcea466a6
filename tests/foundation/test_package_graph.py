"""The package graph, read from the imports: the layering of docs/architecture.md and no cycles.

Every module of every package is parsed (ast: top-level and function-level imports alike, relative
ones resolved), and each import of another amr_* package must be an edge of ALLOWED. Side-by-side
packages may use each other's libraries along an allowed edge but never each other's nodes; control,
localization and planning import neither the simulator nor pymunk (test_without_pymunk checks the
same at run time).
"""

from __future__ import annotations

import ast
import functools
from collections import defaultdict
from graphlib import CycleError, TopologicalSorter
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = sorted(p.parent.name for p in (ROOT / "resource").glob("*/package.xml"))
MESSAGES = "amr_interfaces"
"""Message and service types: every package may import them."""

BOTTOM = {"amr_util"}
MAPS = BOTTOM | {"amr_maps"}
ALLOWED: dict[str, set[str]] = {
    "amr_util": set(),
    "amr_maps": BOTTOM,
    "amr_simulation": MAPS,
    "amr_control": MAPS,
    "amr_localization": MAPS,
    "amr_planning": MAPS,
    "amr_mapping": MAPS,
    "amr_datasets": MAPS,
    "amr_navigation": MAPS | {"amr_control", "amr_planning"},  # the Navigator and its loop drive their libraries
    "amr_kinematics": BOTTOM,
    "amr_turtlebot3": BOTTOM,
    "amr_evaluation": MAPS
    | {
        "amr_simulation",
        "amr_control",
        "amr_localization",
        "amr_planning",
        "amr_kinematics",
        "amr_turtlebot3",
        "amr_navigation",
        "amr_bringup",
        "amr_mapping",
        "amr_datasets",
    },
    "amr_bringup": MAPS
    | {
        "amr_simulation",
        "amr_control",
        "amr_localization",
        "amr_planning",
        "amr_kinematics",
        "amr_turtlebot3",
        "amr_navigation",
        "amr_mapping",
        "amr_datasets",
    },
    "amr_viewer": MAPS | {"amr_kinematics"},  # topics, not imports, for the rest; arms drawn by the chains' own FK
}
"""package -> the amr_* packages its modules may import (besides itself and amr_interfaces)."""
SIDE_BY_SIDE = {
    "amr_simulation",
    "amr_control",
    "amr_localization",
    "amr_planning",
    "amr_kinematics",
    "amr_turtlebot3",
    "amr_mapping",
    "amr_datasets",
}
NO_SIMULATOR = {
    "amr_util",
    "amr_maps",
    "amr_control",
    "amr_localization",
    "amr_planning",
    "amr_kinematics",
    "amr_turtlebot3",
    "amr_navigation",
    "amr_mapping",
    "amr_datasets",
}
"""Packages that run on a real robot: they import neither amr_simulation nor pymunk."""


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def walk_at_run_time(tree: ast.AST, import_time_only: bool = False):
    """ast.walk without the bodies of `if TYPE_CHECKING:` (annotations only, never imported), and with
    import_time_only without function bodies (imported when called, after every module has loaded)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            stack.extend(node.orelse)
        elif not (import_time_only and isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))):
            stack.extend(ast.iter_child_nodes(node))


def imports(path: Path, import_time_only: bool = False) -> set[str]:
    """Absolute names of the modules `path` imports (relative imports resolved against its package)."""
    package = module_name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    names: set[str] = set()
    for node in walk_at_run_time(ast.parse(path.read_text(encoding="utf-8"), str(path)), import_time_only):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join([*base, node.module] if node.module else base)
            names.add(module)
            names.update(f"{module}.{alias.name}" for alias in node.names)  # `from pkg import module`
    return names


@functools.cache
def edges() -> dict[str, dict[str, set[str]]]:
    """importing module -> {imported amr_* module, ...} for every module of every package (parsed once, by the
    first test that asks: not at collection, where every pytest-xdist worker would parse them all)."""
    graph: dict[str, dict[str, set[str]]] = defaultdict(dict)
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            graph[package][module_name(path)] = {
                name for name in imports(path) if name.split(".")[0].startswith("amr_")
            }
    return graph


def test_every_package_has_a_place_in_the_layering():
    assert set(PACKAGES) == set(ALLOWED), "a new package needs its row in ALLOWED (and docs/architecture.md)"


@pytest.mark.parametrize("package", PACKAGES)
def test_imports_follow_the_layering(package):
    wrong = sorted(
        f"{module} imports {name}"
        for module, names in edges()[package].items()
        for name in names
        if name.split(".")[0] not in ALLOWED[package] | {package, MESSAGES}
    )
    assert not wrong, f"{package} may import only {sorted(ALLOWED[package])}:\n" + "\n".join(wrong)


@pytest.mark.parametrize("package", sorted(SIDE_BY_SIDE | {"amr_navigation"}))
def test_side_by_side_packages_import_no_other_package_nodes(package):
    """Nor does amr_navigation: its node talks to the controllers and the planner over ROS, its loop uses
    their libraries."""
    wrong = sorted(
        f"{module} imports {name}"
        for module, names in edges()[package].items()
        for name in names
        if name.split(".")[0] in SIDE_BY_SIDE - {package} and name.endswith("_node")
    )
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("package", sorted(NO_SIMULATOR))
def test_runtime_packages_import_neither_the_simulator_nor_pymunk(package):
    wrong = []
    for path in (ROOT / package).rglob("*.py"):
        for name in imports(path):
            if name.split(".")[0] in {"amr_simulation", "pymunk"}:
                wrong.append(f"{module_name(path)} imports {name}")
    assert not wrong, "\n".join(sorted(wrong))


def test_the_package_graph_has_no_cycle():
    graph = {
        package: {name.split(".")[0] for names in edges()[package].values() for name in names} - {package, MESSAGES}
        for package in PACKAGES
    }
    try:
        order = list(TopologicalSorter(graph).static_order())
    except CycleError as error:
        pytest.fail(f"the packages import each other in a cycle: {error.args[1]}")
    assert (
        order.index("amr_util") < order.index("amr_maps") < order.index("amr_simulation") < order.index("amr_bringup")
    )


def test_the_module_graph_has_no_cycle_at_import_time():
    """No module imports itself back through others while loading (a partially initialized module).
    A module's own ancestor packages do not count: Python initializes them first whatever the module
    imports; nor do imports inside functions, which run after loading (amr_kinematics.chain's kernel)."""
    modules = {
        module_name(path): {name for name in imports(path, import_time_only=True) if name.startswith("amr_")}
        for package in PACKAGES
        for path in (ROOT / package).rglob("*.py")
    }
    graph = {
        module: {name for name in names if name in modules and name != module and not module.startswith(name + ".")}
        for module, names in modules.items()
    }
    try:
        TopologicalSorter(graph).prepare()
    except CycleError as error:
        pytest.fail(f"modules import each other in a cycle: {error.args[1]}")


def test_the_parser_finds_absolute_relative_and_function_level_imports():
    """The tests above would pass on an empty graph: the parser must see every kind of import."""
    assert "amr_maps.world" in edges()["amr_simulation"]["amr_simulation.simulator"]  # absolute
    assert "amr_kinematics.errors" in edges()["amr_kinematics"]["amr_kinematics.solvers.ccd"]  # from ..errors
    assert "amr_util.share" in edges()["amr_kinematics"]["amr_kinematics.urdf"]  # inside a function
