"""The manifests declare what the code imports, under rosdep keys that exist, and nothing else.

A ROS user installing one package from its manifest (rosdep, colcon, a Debian build) gets what
its code needs; a dependency nobody imports is a lie the other way. Imports are read from the
source with the ast module (top-level and function-level alike), mapped to ROS package or
rosdep keys; the Python standard library is skipped.

- resource/<package>/package.xml (what `share/<package>/package.xml` installs) declares exactly the
  run-time imports of that package's code.
- The root package.xml (the one colcon builds, for all packages at once) names every package and
  declares every run-time import of all of them, plus what the tests import.
- Every key is a key of ros/rosdistro: a ROS 2 Jazzy package of jazzy/distribution.yaml or a key of
  rosdep/python.yaml (both checked at ROSDISTRO_COMMIT). A Python dependency without a key (pymunk)
  is declared in no manifest and named, with its pip install, in the README.
"""

from __future__ import annotations

import ast
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = sorted(p.parent.name for p in (ROOT / "resource").glob("*/package.xml"))
OUR_PACKAGES = {*PACKAGES, "amr_interfaces"}

ROSDISTRO_COMMIT = "8468e88ccd523427f9131e39d2af0938f1c298b2"
"""The ros/rosdistro commit (2026-08-22) the two tables below were read from."""
ROSDEP_KEYS = {
    "numpy": "python3-numpy",
    "yaml": "python3-yaml",
    "scipy": "python3-scipy",
    "matplotlib": "python3-matplotlib",
    "PIL": "python3-pil",
    "rosbags": "python3-rosbags-pip",
    "numba": "python3-numba",
    "pytest": "python3-pytest",
    "hypothesis": "python3-hypothesis",
    "transforms3d": "python3-transforms3d",
    "mcap": "mcap-ros2-support",
    "mcap_ros2": "mcap-ros2-support",  # rosdep has no key for mcap alone
    "gymnasium": "python3-gymnasium-pip",
    "tqdm": "python3-tqdm",
}
"""Python import names -> their keys in rosdistro's rosdep/python.yaml."""
JAZZY_PACKAGES = {
    "ament_index_python",
    "builtin_interfaces",
    "geometry_msgs",
    "launch",
    "launch_ros",
    "lifecycle_msgs",
    "nav_msgs",
    "rcl_interfaces",
    "rclpy",
    "rosgraph_msgs",
    "sensor_msgs",
    "std_msgs",
    "std_srvs",
    "tf2_msgs",
}
"""ROS packages of rosdistro's jazzy/distribution.yaml that the suite imports."""
WITHOUT_ROSDEP_KEY = {"pymunk", "contourpy", "distributed", "viser"}
"""Python imports no rosdep key provides: the README says to pip install them."""
TESTS_WITHOUT_ROSDEP_KEY = {"playwright"}
"""The same for the tests (the browser tests drive chromium with it; in the test extras)."""
TEST_HELPERS = {"conftest"}


def imports_of(paths) -> set[str]:
    names: set[str] = set()
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                names.update(alias.name.split(".")[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    return names - set(sys.stdlib_module_names) - {"__future__"}


def keys_of(names: set[str]) -> set[str]:
    """The manifest keys of imported names: our packages and ROS packages as they are, Python modules by
    the table; the ones without a key left out."""
    return {ROSDEP_KEYS.get(name, name) for name in names - WITHOUT_ROSDEP_KEY - TESTS_WITHOUT_ROSDEP_KEY}


def imported_packages(package: str) -> set[str]:
    return keys_of(imports_of((ROOT / package).rglob("*.py"))) - {package}


def declared(manifest: Path, tags=("depend", "exec_depend", "build_export_depend")) -> set[str]:
    root = ET.parse(manifest).getroot()
    return {element.text.strip() for tag in tags for element in root.findall(tag)}


def test_every_package_is_checked():
    assert {
        "amr_util",
        "amr_maps",
        "amr_simulation",
        "amr_control",
        "amr_localization",
        "amr_planning",
        "amr_kinematics",
        "amr_turtlebot3",
        "amr_navigation",
        "amr_evaluation",
        "amr_bringup",
        "amr_viewer",
        "amr_mapping",
        "amr_datasets",
    } == set(PACKAGES)


@pytest.mark.parametrize("package", PACKAGES)
def test_manifest_declares_exactly_what_the_code_imports(package):
    imported = imported_packages(package)
    declared_here = declared(ROOT / "resource" / package / "package.xml")
    assert not imported - declared_here, f"{package}/package.xml misses {sorted(imported - declared_here)}"
    assert not declared_here - imported, f"{package}/package.xml declares unused {sorted(declared_here - imported)}"


def test_the_root_manifest_colcon_builds_covers_every_package():
    root = ET.parse(ROOT / "package.xml").getroot()
    description = root.findtext("description")
    assert all(package in description for package in PACKAGES), "the root description names every package"
    run_time = set().union(*(imported_packages(package) for package in PACKAGES)) - OUR_PACKAGES
    missing = run_time - declared(ROOT / "package.xml")
    assert not missing, f"package.xml (the one colcon builds) misses run-time dependencies {sorted(missing)}"
    unused = declared(ROOT / "package.xml") - run_time - {"amr_interfaces"}
    assert not unused, f"package.xml declares run-time dependencies nobody imports: {sorted(unused)}"


def test_the_root_manifest_covers_what_the_tests_import():
    test_helpers = (
        TEST_HELPERS
        | {path.stem for path in (ROOT / "tests").rglob("*.py")}
        | {path.name for path in (ROOT / "tests").rglob("*") if (path / "__init__.py").is_file()}
    )  # tests/support
    needed = keys_of(imports_of((ROOT / "tests").rglob("*.py")) - test_helpers) - OUR_PACKAGES
    available = declared(ROOT / "package.xml", ("depend", "exec_depend", "build_export_depend", "test_depend"))
    assert not needed - available, f"package.xml misses test dependencies {sorted(needed - available)}"
    unused = declared(ROOT / "package.xml", ("test_depend",)) - needed
    assert not unused, f"package.xml declares test dependencies the tests do not import: {sorted(unused)}"


@pytest.mark.parametrize("manifest", ["package.xml", *(f"resource/{p}/package.xml" for p in PACKAGES)])
def test_every_key_exists_in_rosdistro(manifest):
    tags = ("depend", "exec_depend", "build_export_depend", "test_depend", "build_depend")
    unknown = declared(ROOT / manifest, tags) - OUR_PACKAGES - JAZZY_PACKAGES - set(ROSDEP_KEYS.values())
    assert not unknown, f"{manifest}: no rosdep key {sorted(unknown)} in ros/rosdistro at {ROSDISTRO_COMMIT[:10]}"


def test_dependencies_without_a_rosdep_key_are_named_in_the_readme():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    imported = imports_of(ROOT.glob("amr_*/**/*.py"))
    for module in sorted(WITHOUT_ROSDEP_KEY):
        assert module in imported, f"{module} is no longer imported: drop it from WITHOUT_ROSDEP_KEY"
        assert re.search(rf"pip install [^`\n]*\b{module}\b", readme), (
            f"README.md must say `pip install {module}`: it has no rosdep key"
        )
