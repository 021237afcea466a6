"""An episode through the ROS nodes (the controller's stack composed in a child process, its own domain) gives
the library episode's record: the wall follower, localization and navigation, each to the step."""

from __future__ import annotations

import dataclasses

import numpy as np
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


def test_the_wall_follower_stack_reaches_the_goal_at_the_library_episodes_step(ros_domain, monkeypatch):
    """open_room seed 0 (bench_library_ros's first spec): the goal verdict, its time and collisions the same both
    ways (the test above ends before any goal)."""
    monkeypatch.setenv("AMR_EVALUATE_ROS_DOMAINS", f"{ros_domain}-{ros_domain}")
    label, parameters = configs.resolve("wall_follower", "sim")
    library = EpisodeSpec("wall_follower", label, parameters, {"file": "open_room.yaml"}, seed=0, duration=60.0)
    ros = run_episode(dataclasses.replace(library, mode="ros"))
    expected = run_episode(library)
    assert ros["error"] is None, ros["error"]
    assert expected["goal_reached"] is ros["goal_reached"] is True
    assert ros["time_to_goal"] == pytest.approx(expected["time_to_goal"], abs=1e-6)
    assert ros["collisions"] == expected["collisions"] == 0


def _both_ways(ros_domain, monkeypatch, controller: str, world: str, **spec) -> tuple[dict, dict]:
    """The records of one episode spec (the controller's default configuration) through ROS in its own domain and in
    the library; the ROS run without an error."""
    monkeypatch.setenv("AMR_EVALUATE_ROS_DOMAINS", f"{ros_domain}-{ros_domain}")
    label, parameters = configs.resolve(controller, "default")
    library = EpisodeSpec(controller, label, parameters, {"file": world}, **spec)
    ros = run_episode(dataclasses.replace(library, mode="ros"))
    assert ros["error"] is None, ros["error"]
    return ros, run_episode(library)


def test_the_navigation_stack_reaches_the_goal_at_the_library_episodes_step(ros_domain, monkeypatch):
    """pillar_goal: localized at the third observation, one plan, the goal 8.3 s in (a filter fed other numbers than
    the nodes', or the planner on another map, parts them by a few steps: 8.15 against 8.30 s)."""
    ros, expected = _both_ways(ros_domain, monkeypatch, "navigation", "pillar_goal.yaml", seed=1, duration=20.0)
    assert expected["goal_reached"] is ros["goal_reached"] is True
    assert ros["time_to_goal"] == pytest.approx(expected["time_to_goal"], abs=1e-6)
    assert ros["time_to_localized"] == pytest.approx(expected["time_to_localized"], abs=1e-6)
    assert ros["collisions"] == expected["collisions"] == 0
    assert ros["distance"] == pytest.approx(expected["distance"], rel=1e-3)


def test_an_idle_stretch_goes_on_at_zero_velocity_in_both_and_the_late_goal_is_reached_at_the_same_step(
    ros_domain, monkeypatch
):
    """goal_after: localized at 0.45 s with no goal, the robot stands (nobody drives: the navigator's zero command
    answers each observation, as the library loop's zero) until the goal 0.7 m ahead comes at 1.5 s; then the same
    trip. Before, the lockstep world stood still at the first idle observation and the episode stalled."""
    ros, expected = _both_ways(
        ros_domain,
        monkeypatch,
        "navigation",
        "pillar_goal.yaml",
        goal=[-0.8, -1.0, 0.15],
        seed=1,
        duration=10.0,
        options={"goal_after": 1.5},
    )
    assert expected["goal_reached"] is ros["goal_reached"] is True
    assert expected["time_to_goal"] > 1.5 + 2.0  # the idle stretch, then a trip of about 3 s
    assert ros["time_to_goal"] == pytest.approx(expected["time_to_goal"], abs=1e-6)
    assert ros["time_to_localized"] == pytest.approx(expected["time_to_localized"], abs=1e-6)
    assert expected["time_to_localized"] < 1.5 and expected["extra"]["steps"]["IDLE"] >= 20
    assert ros["collisions"] == expected["collisions"] == 0
    assert ros["distance"] == pytest.approx(expected["distance"], rel=1e-3)


def test_the_localization_stack_localizes_at_the_library_episodes_step_with_its_error(ros_domain, monkeypatch):
    ros, expected = _both_ways(ros_domain, monkeypatch, "localization", "open_room.yaml", seed=0, duration=3.0)
    assert ros["time"] == pytest.approx(expected["time"], abs=1e-6)
    assert ros["time_to_localized"] == pytest.approx(expected["time_to_localized"], abs=1e-6)
    assert ros["localization_error"] == pytest.approx(expected["localization_error"], abs=1e-9)
    assert ros["distance"] == pytest.approx(expected["distance"], rel=1e-3)


def test_the_library_reads_the_scan_and_the_map_as_the_nodes_read_their_messages():
    """What makes the two modes one run: the library's scan, time and map are the messages' to the bit (a filter fed a
    1e-7 difference localizes millimetres elsewhere)."""
    from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import LaserScan

    from amr_evaluation.episode import AsSent, simulator_for, stack_map
    from amr_evaluation.worlds import build_world
    from amr_maps.messages import grid_from_message, grid_message
    from amr_maps.rasterize import rasterize_world
    from amr_simulation import messages
    from amr_util.messages import scan_data
    from amr_util.scan import scan_of
    from amr_util.stamps import stamp_from_seconds, stamp_nanoseconds

    label, parameters = configs.resolve("navigation", "default")
    spec = EpisodeSpec("navigation", label, parameters, {"file": "pillar_goal.yaml"}, seed=1)
    world = build_world(spec.world)
    sim = simulator_for(spec, world)
    while sim.time == stamp_nanoseconds(stamp_from_seconds(sim.time)) * 1e-9:  # a time the float sum is off
        sim.step(0.1, 0.3)
    stamp = stamp_from_seconds(sim.time)
    sent = deserialize_message(
        serialize_message(messages.laser_scan(stamp, "base_scan", sim.ranges, sim.lidar, 0.05)), LaserScan
    )
    node, library = scan_data(sent), scan_of(AsSent(sim))
    assert np.asarray(library.ranges).tobytes() == np.asarray(node.ranges).tobytes()
    fields = ("angle_min", "angle_increment", "range_min", "range_max")
    assert [getattr(library, f) for f in fields] == [getattr(node, f) for f in fields]
    assert AsSent(sim).time == stamp_nanoseconds(sent.header.stamp) * 1e-9  # the controllers' and navigator's time
    served = grid_message(rasterize_world(world, 0.02), stamp)  # map_server's in maze_navigation
    read = grid_from_message(deserialize_message(serialize_message(served), OccupancyGridMessage))
    grid = stack_map(spec, world)
    assert (grid.resolution, grid.origin) == (read.resolution, read.origin) and np.array_equal(grid.data, read.data)


@pytest.mark.parametrize("value", [-1.0, "soon", True, [1.0]])
def test_a_bad_goal_after_gives_a_record_naming_the_option(value):
    label, parameters = configs.resolve("navigation", "default")
    spec = EpisodeSpec("navigation", label, parameters, {"file": "pillar_goal.yaml"}, options={"goal_after": value})
    record = run_episode(spec)
    assert record["error"] is not None and "option goal_after" in record["error"], record["error"]


def test_a_real_robot_configuration_is_refused_with_the_reason(tmp_path):
    label, parameters = configs.resolve("wall_follower", "real")
    spec = EpisodeSpec("wall_follower", label, parameters, {"file": "open_room.yaml"}, mode="ros")
    with pytest.raises(RosEpisodeError, match="simulation: false"):
        stack_of(spec, tmp_path)
