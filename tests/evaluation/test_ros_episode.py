"""An episode through the ROS nodes (the maze_sim stack composed in a child process, its own domain) gives
the library episode's figures."""

from __future__ import annotations

import dataclasses

import pytest

from amr_evaluation import configs
from amr_evaluation.episode import EpisodeSpec, run_episode
from amr_evaluation.ros_episode import RosEpisodeError, stack_of


def test_the_wall_follower_stack_matches_the_library_episode(ros_domain, monkeypatch):
    monkeypatch.setenv("AMR_EVALUATE_ROS_DOMAINS", f"{ros_domain}-{ros_domain}")
    label, parameters = configs.resolve("wall_follower", "sim")
    library = EpisodeSpec(
        "wall_follower",
        label,
        parameters,
        {"file": "open_room.yaml"},
        seed=3,
        lidar_noise=0.02,
        encoder_noise=0.02,
        slip=0.05,
        duration=8.0,
    )
    ros = run_episode(dataclasses.replace(library, mode="ros"))
    expected = run_episode(library)
    assert ros["error"] is None, ros["error"]
    assert ros["extra"]["ros_domain"] == ros_domain
    assert ros["time"] == pytest.approx(expected["time"], abs=1e-6)  # the first status at or past 8 s
    assert ros["collisions"] == expected["collisions"] == 0
    assert ros["goal_reached"] is expected["goal_reached"] is False
    assert ros["distance"] == pytest.approx(expected["distance"], rel=1e-3)


def test_a_real_robot_configuration_is_refused_with_the_reason(tmp_path):
    label, parameters = configs.resolve("wall_follower", "real")
    spec = EpisodeSpec("wall_follower", label, parameters, {"file": "open_room.yaml"}, mode="ros")
    with pytest.raises(RosEpisodeError, match="simulation: false"):
        stack_of(spec, tmp_path)
