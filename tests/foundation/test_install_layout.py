"""The install is a ROS 2 prefix: `ros2 run` finds every node, ament finds every package."""

import os
import sys
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from ament_index_python.packages import get_package_prefix, get_package_share_directory

ROOT = Path(__file__).resolve().parents[2]
PREFIX = Path(sys.prefix)
PACKAGES = ["amr_control", "amr_simulation", "amr_turtlebot3", "amr_kinematics"]
NODES = [(pkg, exe.name) for pkg in PACKAGES for exe in sorted((ROOT / "resource" / "lib" / pkg).iterdir())]


@pytest.mark.parametrize("package", PACKAGES)
def test_package_is_registered_with_its_own_manifest(package, monkeypatch):
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(PREFIX))
    assert Path(get_package_prefix(package)) == PREFIX
    manifest = ET.parse(Path(get_package_share_directory(package)) / "package.xml").getroot()
    assert manifest.get("format") == "3"
    assert manifest.findtext("name") == package


@pytest.mark.parametrize(("package", "executable"), NODES)
def test_every_node_executable_is_installed_and_names_a_real_module(package, executable):
    path = PREFIX / "lib" / package / executable
    assert path.is_file() and os.access(path, os.X_OK)
    module = path.read_text().split(" -m ")[1].split()[0]
    assert (ROOT / (module.replace(".", "/") + ".py")).is_file(), f"{path} runs missing module {module}"


def test_expected_nodes_are_all_there():
    assert {("amr_turtlebot3", "odometry_node"), ("amr_simulation", "simulator"), ("amr_control", "wall_follower"),
            ("amr_control", "lifecycle_manager"), ("amr_kinematics", "ik_service")} <= set(NODES)


def test_ros_wheels_are_pinned_to_jazzy():
    dependencies = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    ros = [d for d in dependencies if d.startswith("ros-")]
    assert ros and all(d.startswith("ros-jazzy-") and "==" in d for d in ros)


def test_config_files_are_installed_next_to_their_package():
    table = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["data-files"]
    for destination, patterns in table.items():
        for pattern in patterns:
            for source in ROOT.glob(pattern):
                assert (PREFIX / destination / source.name).read_bytes() == source.read_bytes(), source
