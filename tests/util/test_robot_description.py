"""The robot description: read once, every library default from it, errors naming file, key and value, and a
node's robot_description parameter laying another robot over the facts it was not given."""

import re
import subprocess
from pathlib import Path

import pytest
import yaml
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.parameter import Parameter

from amr_control.path_follower_config import PathFollowerConfig
from amr_control.wall_follower_config import WallFollowerConfig
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_localization.particle_filter_parameters import NODE_SPECS
from amr_mapping.slam import SlamConfig
from amr_navigation.traffic import TrafficConfig
from amr_planning.costmap import CostmapConfig
from amr_planning.planner_node import PlannerNode
from amr_simulation.config import SimulationConfig
from amr_util.diff_drive import DiffDrive
from amr_util.robot_description import RobotDescriptionError, default_robot, load_robot_description, robot_parameters

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "config" / "robot" / "turtlebot3_burger.yaml"


def test_the_shipped_burger():
    robot = default_robot()
    assert (robot.radius, robot.wheel_radius, robot.wheel_separation) == (0.105, 0.033, 0.16)
    assert (robot.max_linear_speed, robot.max_angular_speed, robot.lidar_x, robot.lidar_beams) == (
        0.22,
        2.84,
        -0.032,
        360,
    )
    assert robot.scan_period == pytest.approx(0.2)


def test_every_library_default_is_the_description():
    robot = default_robot()
    sim = SimulationConfig()
    assert sim.robot.radius == CostmapConfig().robot_radius == TrafficConfig().robot_radius == robot.radius
    assert WallFollowerConfig().robot_radius == PathFollowerConfig().robot_radius == robot.radius
    assert sim.lidar.x == WallFollowerConfig().lidar_x == PathFollowerConfig().lidar_x == robot.lidar_x
    assert ParticleFilterConfig().lidar_x == SlamConfig().lidar_x == robot.lidar_x
    assert ParticleFilterConfig().lidar_y == SlamConfig().lidar_y == robot.lidar_y
    assert {spec.name: spec.default for spec in NODE_SPECS}["laser_max_range"] == robot.lidar_range_max
    assert WallFollowerConfig().angular_limit == PathFollowerConfig().angular_limit == robot.max_angular_speed
    assert (DiffDrive().wheel_radius, DiffDrive().track) == (robot.wheel_radius, robot.wheel_separation)
    assert (sim.robot.track, sim.robot.max_linear, sim.robot.max_wheel_speed) == (
        robot.wheel_separation,
        robot.max_linear_speed,
        robot.max_linear_speed / robot.wheel_radius,
    )


FACTS = (r"0\.105", r"0\.033", r"0\.160", r"2\.84", r"-0\.032", r"0\.172")
"""The description's numbers no other number of the suite shares (footprint, wheels, angular limit, LiDAR mount):
written anywhere else, they are a copy of the robot."""


def test_the_robots_facts_are_written_once():
    """No literal radius, wheel geometry, angular limit or LiDAR mount in the packages and config/ but the
    description."""
    packages = sorted(p.name for p in ROOT.glob("amr_*") if p.is_dir() and not p.name.endswith(".egg-info"))
    found = subprocess.run(
        ["grep", "-rnE", "--include=*.py", "--include=*.yaml", "-e", r"(^|[^0-9.])(" + "|".join(FACTS) + r")\b"]
        + [*packages, "config"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    ).stdout.splitlines()
    copies = [line for line in found if not line.startswith("config/robot/")]
    assert copies == []
    assert len(found) >= len(FACTS)  # the grep does find the description's own


def write(tmp_path, change) -> Path:
    data = yaml.safe_load(SHIPPED.read_text())
    change(data)
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda d: d["footprint"].update(radius=-1.0),
            r"footprint\.radius: must be a number in \[0\.01, 2\], got -1\.0",
        ),
        (lambda d: d["lidar"].update(beams=36.5), r"lidar\.beams: must be an integer in \[1, 10000\], got 36\.5"),
        (lambda d: d["wheels"].pop("separation"), r"wheels\.separation: missing"),
        (lambda d: d["limits"].update(max_speed=1.0), r"unknown key limits\.max_speed"),
        (lambda d: d.update(arm={}), r"unknown section 'arm'"),
    ],
)
def test_errors_name_file_key_and_value(tmp_path, change, message):
    path = write(tmp_path, change)
    with pytest.raises(RobotDescriptionError, match=re.escape(str(path)) + ".*" + message):
        load_robot_description(path)
    with pytest.raises(RobotDescriptionError, match="no_such_robot.yaml.*not found"):
        load_robot_description("no_such_robot.yaml")


def test_a_node_takes_another_robot_for_the_facts_it_was_not_given(tmp_path, ros_context):
    big = write(tmp_path, lambda d: d["footprint"].update(radius=0.2))
    assert robot_parameters(load_robot_description(big))["robot_radius"] == 0.2
    planner = PlannerNode(context=ros_context, parameter_overrides=[Parameter("robot_description", value=str(big))])
    given = PlannerNode(
        context=ros_context,
        parameter_overrides=[Parameter("robot_description", value=str(big)), Parameter("robot_radius", value=0.15)],
    )
    shipped = PlannerNode(context=ros_context)
    bad = PlannerNode(context=ros_context, parameter_overrides=[Parameter("robot_description", value="nope.yaml")])
    try:
        assert planner.parameter_values()["robot_radius"] == 0.2
        assert given.parameter_values()["robot_radius"] == 0.15  # given to the node: kept
        assert shipped.parameter_values()["robot_radius"] == 0.105
        assert "robot_description" not in shipped.parameter_values()
        assert planner.trigger_configure() == TransitionCallbackReturn.SUCCESS
        assert bad.trigger_configure() != TransitionCallbackReturn.SUCCESS  # the missing file refused at configure
    finally:
        for node in (planner, given, shipped, bad):
            node.destroy_node()
