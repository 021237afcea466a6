"""The simulator node in-process, lockstep mode: the seed's contract, services, lifecycle and bad input."""

import math
from itertools import pairwise

import pytest
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.msg import Transition
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger
from support.ros import spin_until
from support.simulator_probe import TIMEOUT, call, change_state, drive, seconds, settle, start, state_of

from amr_interfaces.srv import SetPose
from amr_simulation.config import LidarConfig
from amr_util.geometry import yaw_from_quaternion
from amr_util.qos import LATCHED

OPEN_ROOM = {"world": "open_room.yaml"}  # start (-1.5, -1.0, 0), walls at x = +-2, y = +-1.5 (0.05 thick)
DT = 0.05


def yaw(message) -> float:
    return yaw_from_quaternion(message.pose.pose.orientation)


def test_straight_for_10_s_ends_1_5_m_ahead_on_ground_truth_and_odometry(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    start(executor, node, driver)
    first = driver.ground_truth[0].pose.pose.position
    assert (first.x, first.y) == (-1.5, -1.0)

    drive(executor, driver, [(0.15, 0.0)] * 200)

    for stream in (driver.ground_truth, driver.odometry, driver.odom):
        end = stream[-1].pose.pose.position
        assert end.x == pytest.approx(-1.5 + 1.5, abs=0.01)
        assert end.y == pytest.approx(-1.0, abs=0.01)
        assert abs(yaw(stream[-1])) < 1e-6
    assert driver.odometry[-1].twist.twist.linear.x == pytest.approx(0.15)
    assert driver.ground_truth[-1].twist.twist.linear.x == pytest.approx(0.15)
    assert driver.odom[-1].twist.twist.linear.x == 0.0, "/odom carries no twist, as a real TurtleBot3's"
    assert seconds(driver.odometry[-1].header.stamp) == pytest.approx(200 * DT)
    assert driver.statuses[-1].distance_travelled == pytest.approx(1.5, abs=1e-6)
    assert driver.statuses[-1].real_time_factor > 0.0
    frames = {(m.header.frame_id, m.child_frame_id) for m in driver.odometry + driver.odom}
    assert frames == {("odom", "base_footprint")}
    assert driver.ground_truth[-1].header.frame_id == "map"


def test_n_commands_in_n_observations_out_in_order(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    start(executor, node, driver)
    speeds = [0.005 * k for k in range(1, 31)]
    drive(executor, driver, [(v, 0.0) for v in speeds[:20]])
    # the last 10 as a burst (the /cmd_vel queue holds 10): queued commands are stepped in order
    for v in speeds[20:]:
        driver.send(v)
    assert spin_until(executor, lambda: driver.observations() >= 31, TIMEOUT)
    settle(executor)

    for stream in (driver.odometry, driver.odom, driver.ground_truth, driver.scans, driver.statuses):
        assert len(stream) == 1 + len(speeds), "one first observation, then exactly one per command"
    assert [s.steps for s in driver.statuses] == list(range(31))
    assert [m.twist.twist.linear.x for m in driver.odometry[1:]] == pytest.approx(speeds)
    for stream in (driver.odometry, driver.ground_truth, driver.scans):
        assert [seconds(m.header.stamp) for m in stream] == pytest.approx([k * DT for k in range(31)])
    scan = driver.scans[-1]
    lidar = LidarConfig()
    assert scan.header.frame_id == "base_scan" and len(scan.ranges) == lidar.beams
    assert (scan.angle_min, scan.range_min, scan.range_max) == pytest.approx(
        (lidar.angle_min, lidar.range_min, lidar.range_max)
    )
    assert scan.angle_increment == pytest.approx(lidar.angle_increment)


def test_plain_twist_when_cmd_vel_is_not_stamped(simulator, probe, executor):
    node, driver = simulator(cmd_vel_stamped=False, **OPEN_ROOM), probe(stamped=False)
    start(executor, node, driver)
    drive(executor, driver, [(0.1, 0.5)] * 4)
    assert [m.twist.twist.angular.z for m in driver.odometry[1:]] == pytest.approx([0.5] * 4)
    assert yaw(driver.ground_truth[-1]) == pytest.approx(4 * DT * 0.5)


def test_non_finite_command_still_advances_one_step_at_rest(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    start(executor, node, driver)
    drive(executor, driver, [(math.nan, 0.0), (0.1, math.inf), (0.1, 0.0)])
    assert node.state_label == "active"
    assert [s.steps for s in driver.statuses] == [0, 1, 2, 3]
    assert [m.twist.twist.linear.x for m in driver.ground_truth[1:]] == pytest.approx([0.0, 0.0, 0.1])


def test_observation_topics_can_be_switched_off(simulator, probe, executor):
    node = simulator(publish_odometry=False, publish_scan=False, **OPEN_ROOM)
    driver = probe()
    driver.expected = {"status", "odom", "ground_truth"}
    start(executor, node, driver)
    drive(executor, driver, [(0.1, 0.0)] * 3)
    settle(executor)
    assert (len(driver.odometry), len(driver.scans)) == (0, 0)
    assert (len(driver.odom), len(driver.ground_truth)) == (4, 4)


def test_reset_and_set_pose(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    start(executor, node, driver)
    drive(executor, driver, [(0.2, 0.0)] * 10)

    answer = call(executor, driver.set_pose, SetPose.Request(x=0.5, y=-0.5, theta=math.pi / 2))
    assert answer.success, answer.message
    assert spin_until(executor, lambda: driver.observations() == 12, TIMEOUT), "set_pose publishes the new state"
    for stream in (driver.ground_truth, driver.odometry):
        assert (stream[-1].pose.pose.position.x, stream[-1].pose.pose.position.y) == (0.5, -0.5)
        assert yaw(stream[-1]) == pytest.approx(math.pi / 2)
    drive(executor, driver, [(0.2, 0.0)])
    assert driver.ground_truth[-1].pose.pose.position.y == pytest.approx(-0.5 + 0.2 * DT)

    inside_pillar = call(executor, driver.set_pose, SetPose.Request(x=0.0, y=0.0, theta=0.0))
    assert not inside_pillar.success and "overlaps" in inside_pillar.message
    assert not call(executor, driver.set_pose, SetPose.Request(x=math.nan, y=0.0, theta=0.0)).success

    answer = call(executor, driver.reset, Trigger.Request())
    assert answer.success, answer.message
    assert spin_until(executor, lambda: driver.observations() == 14, TIMEOUT), "reset publishes the start state"
    status, truth = driver.statuses[-1], driver.ground_truth[-1]
    assert (status.steps, status.sim_time, status.collisions, status.distance_travelled) == (0, 0.0, 0, 0.0)
    assert (truth.pose.pose.position.x, truth.pose.pose.position.y) == (-1.5, -1.0)
    stamps = [seconds(m.header.stamp) for m in driver.ground_truth]
    assert all(later > earlier for earlier, later in pairwise(stamps)), "stamps never go back"


def test_a_failed_teleport_then_a_failed_reset_are_both_answered(simulator, probe, executor, monkeypatch):
    """The two are logged at two severities (warning, error) from one answering method: rclpy's logger keeps one
    severity per calling line, so each has its own (else the second raised out of the service callback)."""
    node, driver = simulator(**OPEN_ROOM), probe()
    start(executor, node, driver)
    assert not call(executor, driver.set_pose, SetPose.Request(x=math.nan, y=0.0, theta=0.0)).success

    def broken():
        raise RuntimeError("no start pose")

    monkeypatch.setattr(node._control, "reset", broken)
    answer = call(executor, driver.reset, Trigger.Request())
    assert answer is not None and not answer.success and "no start pose" in answer.message


def test_ramming_a_wall_counts_one_collision_and_stays_out(simulator, probe, executor):
    # facing the east wall (inner face at x = 1.975) from 0.5 m away; 80 steps would drive 1.6 m
    node, driver = simulator(start=[1.3, 0.0, 0.0], **OPEN_ROOM), probe()
    start(executor, node, driver)
    drive(executor, driver, [(0.2, 0.0)] * 80)
    status = driver.statuses[-1]
    assert status.collisions == 1 and status.in_contact
    assert driver.ground_truth[-1].pose.pose.position.x <= 1.975 - 0.105 + 0.01
    assert driver.ground_truth[-1].twist.twist.linear.x == pytest.approx(0.0, abs=1e-6)


def test_goal_reached_stops_the_robot(simulator, probe, executor):
    # open_room's goal: (1.5, -1.25) radius 0.2, entered after 0.3 m at 0.2 m/s (30 steps)
    node, driver = simulator(start=[1.0, -1.25, 0.0], **OPEN_ROOM), probe()
    start(executor, node, driver)
    drive(executor, driver, [(0.2, 0.0)] * 40)
    reached = [s.goal_reached for s in driver.statuses]
    assert reached.index(True) == 30
    assert driver.ground_truth[-1].pose.pose.position.x == pytest.approx(driver.ground_truth[30].pose.pose.position.x)


def test_without_stop_at_goal_the_goal_is_judged_and_reported_and_the_robot_drives_on(simulator, probe, executor):
    node, driver = simulator(start=[1.0, -1.25, 0.0], stop_at_goal=False, **OPEN_ROOM), probe()
    goals = []
    driver.create_subscription(PoseStamped, "simulator/goal", goals.append, LATCHED)  # the world's goal, latched
    start(executor, node, driver)
    assert spin_until(executor, lambda: goals, TIMEOUT)
    goal = goals[-1]
    assert (goal.header.frame_id, goal.pose.position.x, goal.pose.position.y) == ("map", 1.5, -1.25)
    drive(executor, driver, [(0.2, 0.0)] * 40)
    assert [s.goal_reached for s in driver.statuses].index(True) == 30
    assert driver.ground_truth[-1].pose.pose.position.x == pytest.approx(
        driver.ground_truth[30].pose.pose.position.x + 0.1
    )


def test_services_answer_only_while_active(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    executor.add_node(node)
    executor.add_node(driver)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert spin_until(executor, lambda: driver.reset.service_is_ready(), TIMEOUT)
    refused = call(executor, driver.set_pose, SetPose.Request(x=0.5, y=-0.5, theta=0.0))
    assert not refused.success and "simulator is inactive" in refused.message and "only while active" in refused.message
    assert not call(executor, driver.reset, Trigger.Request()).success
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert call(executor, driver.set_pose, SetPose.Request(x=0.5, y=-0.5, theta=0.0)).success


def test_render_writes_a_png_and_answers_its_path(simulator, probe, executor, tmp_path):
    target = tmp_path / "view.png"
    node, driver = simulator(render_path=str(target), **OPEN_ROOM), probe()
    start(executor, node, driver)
    drive(executor, driver, [(0.2, 0.3)] * 5)
    answer = call(executor, driver.render, Trigger.Request())
    assert answer.success and answer.message == str(target)
    assert target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    node.set_parameters([Parameter("render_path", value=str(tmp_path / "no" / "dir.png"))])
    answer = call(executor, driver.render, Trigger.Request())
    assert not answer.success and "render failed" in answer.message


def test_invalid_transition_is_refused_and_lifecycle_runs_through(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    executor.add_node(node)
    executor.add_node(driver)
    assert not change_state(executor, driver, Transition.TRANSITION_ACTIVATE)
    assert state_of(executor, driver) == "unconfigured"
    assert change_state(executor, driver, Transition.TRANSITION_CONFIGURE)
    assert not change_state(executor, driver, Transition.TRANSITION_CONFIGURE)
    assert change_state(executor, driver, Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: driver.observations() == 1, TIMEOUT)
    assert change_state(executor, driver, Transition.TRANSITION_DEACTIVATE)
    driver.send(0.1)
    settle(executor, 0.3)
    assert len(driver.statuses) == 1, "an inactive simulator does not step"
    assert change_state(executor, driver, Transition.TRANSITION_CLEANUP)
    assert driver.count_publishers("/ground_truth") == 0 and not driver.set_pose.service_is_ready()
    assert state_of(executor, driver) == "unconfigured"


BAD_WORLD = """\
wall_thickness: 0.02
walls:
  - [0.0, 0.0, 1.0]
start: [0.5, 0.5, 0.0]
"""


@pytest.mark.parametrize(
    ("params", "named"),
    [
        ({"world": "BAD"}, "walls[0]"),
        ({"world": "no_such_world.yaml"}, "no_such_world.yaml"),
        ({"dt": -0.05}, "dt"),
        ({"mode": "fast"}, "mode"),
        ({"lidar.beam": 60}, "lidar.beam"),  # a typo, not silently ignored
        ({"start": [-1.9, -1.0, 0.0]}, "overlaps"),
    ],
)
def test_bad_configuration_fails_configure_naming_the_key(simulator, probe, executor, tmp_path, capfd, params, named):
    if params.get("world") == "BAD":
        params = {"world": str(tmp_path / "bad.yaml")}
        (tmp_path / "bad.yaml").write_text(BAD_WORLD)
    node, driver = simulator(**{**OPEN_ROOM, **params}), probe()
    executor.add_node(node)
    executor.add_node(driver)
    assert not change_state(executor, driver, Transition.TRANSITION_CONFIGURE)
    assert state_of(executor, driver) == "unconfigured"
    assert driver.count_publishers("/ground_truth") == 0 and not driver.reset.service_is_ready(), "half-built"
    error_lines = [line for line in capfd.readouterr().err.splitlines() if "configure failed" in line]
    assert error_lines and named in error_lines[0]

    if "lidar.beam" not in params:  # fixed at run time, configure then succeeds
        node.set_parameters([Parameter(name, value=LIBRARY_DEFAULTS[name]) for name in params])
        assert change_state(executor, driver, Transition.TRANSITION_CONFIGURE)
        assert driver.count_publishers("/ground_truth") == 1


LIBRARY_DEFAULTS = {"world": "open_room.yaml", "dt": 0.05, "mode": "lockstep", "start": []}
