"""The wall follower's parameters: the two shipped files, defaults, and refusals that name the key."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
import yaml

from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import (
    ConfigError,
    WallFollowerConfig,
    parameter_defaults,
    read_parameter_file,
)
from amr_util.robot_description import default_robot, robot_parameters

CONFIG = Path(__file__).resolve().parents[2] / "config"
FILES = ("wall_follower_sim.yaml", "wall_follower_real.yaml")


@pytest.mark.parametrize("name", FILES)
def test_shipped_files_set_every_key_with_its_ros_type(name):
    raw = yaml.safe_load((CONFIG / name).read_text())["wall_follower"]["ros__parameters"]
    defaults = parameter_defaults()
    # nothing left to a default the reader cannot see, but the robot's facts: the robot description's (the real
    # robot's file saturates lower than the robot can turn: the seed's 0.34 rad/s)
    facts = set(robot_parameters(default_robot())) & set(defaults)
    assert facts == {"robot_radius", "lidar_x", "angular_limit"}
    assert set(raw) - facts == set(defaults) - facts
    assert set(raw) & facts == ({"angular_limit"} if name == "wall_follower_real.yaml" else set())
    for key, value in raw.items():
        # rclpy types parameters from YAML: 1 is an integer, 1.0 a double.
        assert type(value) is type(defaults[key]), f"{name}: {key} is {type(value).__name__}"
    read_parameter_file(CONFIG / name)


def test_defaults_are_the_simulation_file():
    assert read_parameter_file(CONFIG / "wall_follower_sim.yaml") == WallFollowerConfig()


def test_real_robot_file_has_the_seed_values():
    real = read_parameter_file(CONFIG / "wall_follower_real.yaml")
    assert (real.kp, real.kd, real.front_threshold, real.turn_speed, real.angular_limit) == (7.6, 6.0, 0.28, 0.37, 0.34)
    assert (real.sync_slop, real.simulation, real.flip_angular_sign) == (0.15, False, True)


def test_ints_pass_for_floats_but_not_the_reverse():
    assert WallFollowerConfig.from_params({"kp": 4}).kp == 4.0
    with pytest.raises(ConfigError, match="sync_queue_size: must be an integer"):
        WallFollowerConfig.from_params({"sync_queue_size": 10.0})


@pytest.mark.parametrize(
    "params, match",
    [
        ({"kpp": 1.0}, "kpp: unknown parameter"),
        ({"scan_median_beams": 4}, "scan_median_beams: must be odd"),
        ({"scan_median_beams": 0}, "scan_median_beams: must be positive"),
        ({"open_sweep_deg": 80.0}, "open_sweep_deg: must be in"),
        ({"wall_lost_hysteresis": -0.01}, "wall_lost_hysteresis: must be >= 0"),
        ({"open_travel_distance": 0.0}, "open_travel_distance: must be positive"),
        ({"kp": "4"}, "kp: must be a number"),
        ({"kp": True}, "kp: must be a number"),
        ({"simulation": 1}, "simulation: must be true or false"),
        ({"preferred_wall": 1}, "preferred_wall: must be a string"),
        ({"preferred_wall": "center"}, "preferred_wall: must be one of"),
        ({"kp": -1.0}, "kp: must be >= 0"),
        ({"linear_speed": 0.0}, "linear_speed: must be positive"),
        ({"dt": math.nan}, "dt: must be finite"),
        ({"angular_limit": math.inf}, "angular_limit: must be finite"),
        ({"side_window_deg": 90.0}, r"side_window_deg: must be in \[1, 90\), got 90.0"),  # a half width below 90 deg
        ({"abeam_window_deg": 30.0}, "abeam_window_deg"),
        ({"turn_exit_distance": 0.2}, "turn_exit_distance"),
        ({"wall_lost_distance": 0.1}, "wall_lost_distance"),
    ],
)
def test_bad_parameters_are_refused_naming_the_key(params, match):
    with pytest.raises(ConfigError, match=match):
        WallFollowerConfig.from_params(params)
    with pytest.raises(ConfigError, match=match):
        WallFollower(params)


def test_unreadable_files_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="cannot read"):
        read_parameter_file(tmp_path / "missing.yaml")
    other = tmp_path / "other.yaml"
    other.write_text("simulator:\n  ros__parameters: {}\n")
    with pytest.raises(ConfigError, match="no 'wall_follower: ros__parameters:' section"):
        read_parameter_file(other)


def test_follower_accepts_a_dict_a_config_or_nothing():
    assert WallFollower({"kp": 5.0}).config.kp == 5.0
    config = dataclasses.replace(WallFollowerConfig(), kd=1.0)
    assert WallFollower(config).config is config
    assert WallFollower().config == WallFollowerConfig()
