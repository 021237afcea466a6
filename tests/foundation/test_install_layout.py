"""The install is a ROS 2 prefix: `ros2 run` finds every node, ament finds every package."""

import os
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from ament_index_python.packages import get_package_prefix, get_package_share_directory

ROOT = Path(__file__).resolve().parents[2]
PREFIX = Path(sys.prefix)
PACKAGES = sorted(p.parent.name for p in (ROOT / "resource").glob("*/package.xml"))
NODES = [(pkg, exe.name) for pkg in PACKAGES for exe in sorted((ROOT / "resource" / "lib" / pkg).glob("*"))]


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
    assert {
        ("amr_turtlebot3", "odometry_node"),
        ("amr_simulation", "simulator"),
        ("amr_control", "wall_follower"),
        ("amr_bringup", "lifecycle_manager"),
        ("amr_kinematics", "ik_service"),
        ("amr_maps", "map_server"),
        ("amr_bringup", "recorder"),
        ("amr_planning", "planner"),
        ("amr_control", "path_follower"),
        ("amr_localization", "particle_filter"),
        ("amr_localization", "beacon_localizer"),
        ("amr_maps", "maze"),
        ("amr_viewer", "viewer"),
    } <= set(NODES)


def test_every_package_is_installed():
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


def activated_environment(**given: str) -> dict[str, str]:
    """The environment a bash that sources the venv's activate script ends up with."""
    script = f'. "{PREFIX}/bin/activate" && . "{PREFIX}/bin/activate" && env'  # twice: idempotent
    output = subprocess.run(
        ["bash", "-c", script],
        env={"HOME": os.environ.get("HOME", "/"), **given},
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return dict(line.split("=", 1) for line in output.splitlines() if "=" in line)


def test_activating_the_venv_sets_the_ros_environment():
    if sys.prefix == sys.base_prefix:
        pytest.skip("not in a venv")
    env = activated_environment()
    assert env["AMENT_PREFIX_PATH"] == str(PREFIX)
    assert (env["ROS_DISTRO"], env["ROS_VERSION"], env["ROS_PYTHON_VERSION"]) == ("jazzy", "2", "3")
    sourced = activated_environment(AMENT_PREFIX_PATH="/opt/ros/jazzy", ROS_DISTRO="jazzy", ROS_VERSION="2")
    assert sourced["AMENT_PREFIX_PATH"] == f"{PREFIX}:/opt/ros/jazzy", "a sourced Jazzy install is kept"
