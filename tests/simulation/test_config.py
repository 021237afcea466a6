"""Parameters: defaults, the shipped ROS parameter file, and errors naming the parameter."""

from __future__ import annotations

import array
import math
from pathlib import Path

import pytest
from support.simulation import WORLDS

from amr_simulation.config import SimulationConfig, param_defaults, read_parameter_file
from amr_simulation.simulator import Simulator
from amr_util.parameter_spec import ConfigError
from amr_util.robot_description import default_robot, robot_parameters

PARAMETER_FILE = Path(__file__).resolve().parents[2] / "config" / "simulator.yaml"


def test_defaults_round_trip_through_the_flat_dict() -> None:
    params = param_defaults()
    assert params["lidar.beams"] == 240 and params["robot.track"] == 0.16 and params["mode"] == "lockstep"
    assert "start" not in params
    assert SimulationConfig.from_params(params) == SimulationConfig()


def test_defaults_have_ros_friendly_types() -> None:
    for name, value in param_defaults().items():
        assert isinstance(value, (bool, int, float, str)), name


def test_shipped_parameter_file_matches_the_defaults_and_builds_a_simulator() -> None:
    params = read_parameter_file(PARAMETER_FILE)
    assert SimulationConfig.from_params(params) == SimulationConfig()
    described = set(robot_parameters(default_robot()))  # the robot's facts: from its description, not repeated
    assert set(params) == set(param_defaults()) - described and not set(params) & described
    sim = Simulator.from_params(params, [WORLDS])
    assert sim.world.name == "outer_corridor" and sim.pose == sim.world.start


def test_nested_dicts_start_override_and_ignored_names() -> None:
    config = SimulationConfig.from_params(
        {"lidar": {"beams": 60}, "start": [0.6, -0.6, 4.0], "node_only": 1}, ignore=["node_only"]
    )
    assert config.lidar.beams == 60 and config.start == (0.6, -0.6, 4.0)
    from_rclpy = SimulationConfig.from_params({"start": array.array("d", [0.6, -0.6, 4.0])})
    assert from_rclpy.start == (0.6, -0.6, 4.0)
    assert SimulationConfig.from_params({"start": []}).start is None


@pytest.mark.parametrize(
    ("params", "key"),
    [
        ({"lidar.beamz": 1}, "lidar.beamz"),
        ({"dtt": 0.1}, "dtt"),
        ({"lidar.beams": 0}, "lidar.beams"),
        ({"lidar.beams": 2.5}, "lidar.beams"),
        ({"lidar.method": "raymarch"}, "lidar.method"),
        ({"lidar.range_max": 0.1}, "lidar.range_max"),
        ({"lidar.fov": 7.0}, "lidar.fov"),
        ({"robot.wheel_radius": -0.033}, "robot.wheel_radius"),
        ({"robot.track": "wide"}, "robot.track"),
        ({"dt": 0.0}, "dt"),
        ({"dt": True}, "dt"),
        ({"mode": "fast"}, "mode"),
        ({"command_timeout": -1.0}, "command_timeout"),
        ({"encoders.slip": -0.1}, "encoders.slip"),
        ({"cmd_vel_stamped": "yes"}, "cmd_vel_stamped"),
        ({"start": [1.0, 2.0]}, "start"),
        ({"start": [1.0, 2.0, math.nan]}, "start"),
    ],
)
def test_bad_parameters_name_the_key(params: dict, key: str) -> None:
    with pytest.raises(ConfigError) as info:
        SimulationConfig.from_params(params)
    assert str(info.value).startswith(f"{key}: ")


def test_parameter_file_without_the_node_section(tmp_path: Path) -> None:
    other = tmp_path / "other.yaml"
    other.write_text("wall_follower:\n  ros__parameters:\n    dt: 0.05\n")
    with pytest.raises(ConfigError, match="simulator: ros__parameters"):
        read_parameter_file(other)


def test_from_params_reports_a_missing_world() -> None:
    with pytest.raises(ValueError, match="atlantis.yaml"):
        Simulator.from_params({"world": "atlantis.yaml"}, [WORLDS])
