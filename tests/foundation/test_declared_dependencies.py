"""Each package's package.xml declares exactly what its code imports, and nothing else.

A ROS user installing one package from its manifest (rosdep, colcon, a Debian build) gets what
its code needs; a dependency nobody imports is a lie the other way. Imports are read from the
source with the ast module (top-level and function-level alike), mapped to ROS package or
rosdep keys; the Python standard library is skipped.
"""

from __future__ import annotations

import ast
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = sorted(p.parent.name for p in (ROOT / "resource").glob("*/package.xml"))
ROSDEP_KEYS = {
    "numpy": "python3-numpy", "yaml": "python3-yaml", "pymunk": "python3-pymunk", "scipy": "python3-scipy",
    "matplotlib": "python3-matplotlib", "transforms3d": "python3-transforms3d", "PIL": "python3-pil",
    "rosbags": "python3-rosbags", "mcap": "python3-mcap", "numba": "python3-numba", "contourpy": "python3-contourpy",
    "viser": "python3-viser",
}
"""Python distributions -> their rosdep keys (what package.xml names)."""


def imported_packages(package: str) -> set[str]:
    names: set[str] = set()
    for path in (ROOT / package).rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                names.update(alias.name.split(".")[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    names -= set(sys.stdlib_module_names) | {"__future__", package}
    return {ROSDEP_KEYS.get(name, name) for name in names}


def declared_dependencies(package: str) -> set[str]:
    manifest = ET.parse(ROOT / "resource" / package / "package.xml").getroot()
    tags = ("depend", "exec_depend", "build_export_depend")
    return {element.text.strip() for tag in tags for element in manifest.findall(tag)}


def test_every_package_is_checked():
    assert {"amr_util", "amr_bringup", "amr_control", "amr_simulation", "amr_kinematics"} <= set(PACKAGES)


@pytest.mark.parametrize("package", PACKAGES)
def test_manifest_declares_exactly_what_the_code_imports(package):
    imported = imported_packages(package)
    declared = declared_dependencies(package)
    assert not imported - declared, f"{package}/package.xml misses {sorted(imported - declared)}"
    assert not declared - imported, f"{package}/package.xml declares unused {sorted(declared - imported)}"
