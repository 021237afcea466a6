"""The navigator core (amr_navigation.navigator_core): the confidence rule, and the navigator node and the library loop
taking the same decisions on one recorded sequence of observations (one robot, one copy)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.msg import Transition
from rclpy.parameter import Parameter
from rclpy.task import Future

from amr_control.path_follower import PathError, PathFollower
from amr_control.wall_follower import Command
from amr_interfaces.msg import LocalizedPose, PathFollowerStatus
from amr_interfaces.srv import FollowPath, PlanPath
from amr_maps.occupancy_grid import OccupancyGrid
from amr_navigation.loop import NavigationLoop
from amr_navigation.navigator import Controller, Mode
from amr_navigation.navigator_core import ConfidenceGate
from amr_planning.errors import PlanningError
from amr_planning.messages import path_message
from amr_planning.planner import Planner, PlannerConfig
from amr_util.messages import path_points, quaternion
from amr_util.scan import ScanData

NO_RETURNS = ScanData(np.full(240, np.inf), 0.0, 2 * math.pi / 240, 0.12, 3.5)
GOAL = (2.5, 0.5)


def corridor_grid() -> OccupancyGrid:
    """A free 1 x 3 m area at 0.05 m closed by a one-cell wall."""
    data = np.zeros((20, 60), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyGrid(data, 0.05, (0.0, 0.0, 0.0))


def corridor_planner() -> Planner:
    return Planner(corridor_grid(), PlannerConfig(resolution=0.05))


class StandingWallFollower:
    def compute(self, scan, v, w, stamp) -> Command:
        return Command(0.1, 0.3)


# -- the confidence rule ------------------------------------------------------------------------------------


def test_the_gate_drives_from_drive_confidence_until_under_release_confidence():
    gate = ConfidenceGate(drive=0.9, release=0.5)
    sequence = [(False, 0.3), (False, 0.89), (True, 0.92), (False, 0.7), (True, 0.51), (False, 0.49), (True, 0.8)]
    assert [gate.update(localized, confidence) for localized, confidence in sequence] == [
        False,
        False,
        True,  # reached drive
        True,  # the localizer withdrew, the confidence still above release: driving on
        True,
        False,  # under release
        False,  # not yet drive again
    ]


def test_a_localized_pose_without_a_probability_counts_as_sure_and_bad_thresholds_are_refused():
    gate = ConfidenceGate()
    assert gate.update(True, 0.0) and gate.update(True, None) and not gate.update(False, 0.0)
    assert ConfidenceGate.confidence(False, math.nan) == 0.0
    with pytest.raises(ValueError, match="release_confidence"):
        ConfidenceGate(drive=0.6, release=0.7)
    with pytest.raises(ValueError, match="drive_confidence"):
        ConfidenceGate(drive=1.5, release=0.5)


def test_the_loop_follows_its_path_through_a_dip_of_localized_and_explores_under_release():
    loop = NavigationLoop(corridor_planner(), StandingWallFollower(), PathFollower(), GOAL)
    assert loop.step((0.5, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.0, confidence=0.9).mode is Mode.EXPLORE
    assert loop.step((0.5, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.05, confidence=0.97).mode is Mode.FOLLOW
    dip = loop.step((0.55, 0.5, 0.0), False, NO_RETURNS, 0.1, 0.0, 0.1, confidence=0.7)
    assert dip.mode is Mode.FOLLOW and dip.decision.controller is Controller.PATH_FOLLOWER
    assert dip.confident and dip.confidence == 0.7  # the navigator's verdict, not the localizer's
    assert not loop.confident(False, 0.3) and loop.confident(False, 0.7)  # peeked: the gate still sure
    assert loop.localization_losses == 0 and loop.plans == 1
    lost = loop.step((0.6, 0.5, 0.0), False, NO_RETURNS, 0.1, 0.0, 0.15, confidence=0.3)
    assert lost.mode is Mode.EXPLORE and loop.localization_losses == 1 and not lost.confident
    assert loop.step((0.6, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.2, confidence=0.96).mode is Mode.FOLLOW
    assert loop.plans == 1  # back on the same path


# -- the node and the library on one sequence ----------------------------------------------------------------


def recorded_sequence() -> list[tuple]:
    """(stamp, pose, localized, confidence, goal or None): explore, localize, follow through a dip of localized, stray,
    a new goal, a loss and a return, the goal reached, then a goal off the map."""
    steps: list[tuple] = [(0.0, (0.5, 0.5, 0.0), False, 0.2, None), (0.05, (0.5, 0.5, 0.0), True, 0.97, None)]
    t = 0.1
    for k in range(10):
        localized, confidence = (False, 0.7) if k in (4, 5) else (True, 0.97)
        steps.append((t, (0.55 + 0.05 * k, 0.5, 0.0), localized, confidence, None))
        t += 0.05
    steps.append((t, (1.1, 0.78, 0.3), True, 0.97, None))  # strayed 0.28 m: planned again
    t += 0.05
    steps.append((t, (1.15, 0.7, 0.0), True, 0.97, (2.0, 0.3)))  # a new goal
    t += 0.05
    steps.append((t, (1.2, 0.6, 0.0), False, 0.2, None))  # lost: explores
    t += 0.05
    for k in range(18):  # back, along the path to the new goal
        x = 1.2 + 0.05 * (k + 1)
        steps.append((t, (min(x, 2.0), 0.6 - 0.3 * min(1.0, (k + 1) / 16), 0.0), True, 0.98, None))
        t += 0.05
    steps.append((t, (2.0, 0.3, 0.0), True, 0.98, (10.0, 10.0)))  # a goal off the map: refused
    steps.append((t + 0.05, (2.0, 0.3, 0.0), True, 0.98, None))
    return steps


def run_library(steps) -> tuple[list[tuple], list, list[PathFollowerStatus]]:
    loop = NavigationLoop(corridor_planner(), StandingWallFollower(), PathFollower(), GOAL)
    handed: list[np.ndarray] = []
    original = loop.path_follower.set_path

    def set_path(path):
        handed.append(np.asarray(path, dtype=float))
        return original(path)

    loop.path_follower.set_path = set_path
    decisions, reports = [], []
    for stamp, pose, localized, confidence, goal in steps:
        if goal is not None:
            loop.set_goal(goal)
        command = loop.step(pose, localized, NO_RETURNS, 0.0, 0.0, stamp, confidence=confidence)
        decision = command.decision
        decisions.append(
            (
                decision.mode.value,
                decision.controller.value,
                decision.reason,
                loop.plans,
                command.confidence,
                command.confident,
            )
        )
        report = None
        if command.follow is not None:
            follow = command.follow
            report = PathFollowerStatus(
                state=follow.state.value, reached=follow.reached, replan=follow.replan, message=follow.message
            )
            report.header.stamp = stamp_message(stamp)
        reports.append(report)
    return decisions, handed, reports


def stamp_message(seconds: float) -> Time:
    nanoseconds = round(seconds * 1e9)
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


class Recorder:
    def __init__(self) -> None:
        self.messages: list = []

    def publish(self, message) -> None:
        self.messages.append(message)


class PlanClient:
    """The planner node's ~/plan answered in process by the same Planner."""

    srv_name = "/planner/plan"

    def __init__(self, planner: Planner) -> None:
        self.planner = planner

    def service_is_ready(self) -> bool:
        return True

    def call_async(self, request: PlanPath.Request) -> Future:
        start = (request.start.pose.position.x, request.start.pose.position.y)
        goal = (request.goal.pose.position.x, request.goal.pose.position.y)
        planner = self.planner
        if request.obstacles:  # the traffic rules' marks, on a copy of the costmap
            marks = np.array([(point.x, point.y) for point in request.obstacles])
            planner = planner.with_obstacles(marks, request.mark_radius)
        try:
            response = PlanPath.Response(success=True, path=path_message(planner.plan(start, goal), "map", Time()))
        except PlanningError as error:
            response = PlanPath.Response(success=False, message=str(error), goal_refused=error.goal_refused)
        future = Future()
        future.set_result(response)
        return future


class FollowClient:
    """The path follower's ~/follow_path: the path checked by a PathFollower, as the node does."""

    srv_name = "/path_follower/follow_path"

    def __init__(self) -> None:
        self.paths: list[np.ndarray] = []

    def service_is_ready(self) -> bool:
        return True

    def call_async(self, request: FollowPath.Request) -> Future:
        points = path_points(request.path)
        self.paths.append(points)
        try:
            PathFollower().set_path(points)
            response = FollowPath.Response(success=True)
        except PathError as error:
            response = FollowPath.Response(success=False, message=str(error))
        future = Future()
        future.set_result(response)
        return future


def run_node(ros_context, steps, reports) -> tuple[list[tuple], list]:
    from amr_navigation.navigator_node import NavigatorNode

    node = NavigatorNode(context=ros_context, parameter_overrides=[Parameter("goal", value=list(GOAL))])
    try:
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
        statuses = node._outputs["status"] = Recorder()
        node._outputs["path"] = Recorder()
        follow = node._service_clients["follow"] = FollowClient()
        node._service_clients["plan"] = PlanClient(corridor_planner())
        decisions = []
        for (stamp, pose, localized, confidence, goal), report in zip(steps, reports, strict=True):
            if goal is not None:
                message = PoseStamped()
                message.header.frame_id = "map"
                message.pose.position.x, message.pose.position.y = goal
                node._on_goal(message)
            estimate = LocalizedPose(localized=localized, confidence=confidence)
            estimate.header.stamp, estimate.header.frame_id = stamp_message(stamp), "map"
            estimate.pose.pose.position.x, estimate.pose.pose.position.y = pose[0], pose[1]
            estimate.pose.pose.orientation = quaternion(pose[2])
            node._on_pose(estimate)
            status = statuses.messages[-1]
            assert status.header.stamp == estimate.header.stamp
            names = {"wall_follower": "wall_follower", "path_follower": "path_follower", "": ""}
            decisions.append(
                (
                    status.mode,
                    names[status.controller],
                    status.reason,
                    status.plans,
                    status.confidence,
                    status.confident,
                )
            )
            if report is not None:
                node._on_follower(report)
        return decisions, follow.paths
    finally:
        node.destroy_node()


def test_the_node_and_the_library_take_the_same_decisions_on_one_sequence(ros_context):
    steps = recorded_sequence()
    library, library_paths, reports = run_library(steps)
    node, node_paths = run_node(ros_context, steps, reports)
    modes = [decision[0] for decision in library]
    assert {"EXPLORE", "FOLLOW", "REACHED", "NO_PATH"} <= set(modes), modes  # the sequence covers every hand-over
    assert modes[6:8] == ["FOLLOW", "FOLLOW"]  # through the dip of localized (confidence 0.7)
    assert [decision[4:] for decision in library[:2]] == [(0.2, False), (0.97, True)]
    assert [decision[4:] for decision in library[6:8]] == [(0.7, True), (0.7, True)]  # confident through the dip
    assert library[14][4:] == (0.2, False)  # lost
    assert library[-1][3] >= 3  # first plan, stray, new goal
    for k, (ours, theirs) in enumerate(zip(library, node, strict=True)):
        assert ours == theirs, f"observation {k} at {steps[k][0]:.2f} s: library {ours}, node {theirs}"
    assert len(library_paths) == len(node_paths) >= 3
    for ours, theirs in zip(library_paths, node_paths, strict=True):
        assert np.allclose(ours, theirs)


def test_with_the_traffic_rules_the_node_and_the_library_limit_and_hold_alike(ros_context):
    """Something not on the map 0.22 m ahead of r1 (r2 beside it on the board): r1's rules hold it, then plan around;
    the node's speed limits, statuses and paths are the library's, observation by observation."""
    from sensor_msgs.msg import LaserScan

    from amr_maps.messages import grid_message
    from amr_navigation.navigator_node import NavigatorNode
    from amr_navigation.traffic import Traffic
    from amr_navigation.traffic_board import TrafficBoard, TrafficPost

    other = TrafficPost("r2", 1, (2.6, 0.8, math.pi), None)
    ranges = np.full(240, np.inf)
    ranges[[0, 1, 2, 238, 239]] = 0.22
    ahead = ScanData(ranges, 0.0, 2 * math.pi / 240, 0.12, 3.5)
    steps = [(0.0, (0.5, 0.5, 0.0), False, 0.2)] + [
        (0.05 * (k + 1), (0.5 + 0.002 * k, 0.5, 0.0), True, 0.97) for k in range(60)
    ]
    board = TrafficBoard()
    board.post(other)
    planner = corridor_planner()
    loop = NavigationLoop(planner, StandingWallFollower(), PathFollower(), GOAL, traffic=Traffic("r1", 0, board))
    handed: list[np.ndarray] = []
    original = loop.path_follower.set_path
    loop.path_follower.set_path = lambda path: (handed.append(np.asarray(path, dtype=float)), original(path))
    library = []
    for stamp, pose, localized, confidence in steps:
        command = loop.step(pose, localized, ahead, 0.0, 0.0, stamp, confidence=confidence)
        decision = command.decision
        library.append((decision.mode.value, decision.controller.value, command.speed_limit))

    node = NavigatorNode(
        context=ros_context,
        namespace="/r1",
        parameter_overrides=[Parameter("goal", value=list(GOAL)), Parameter("traffic", value=True)],
    )
    try:
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
        for name in ("status", "path", "speed_limit", "traffic"):
            node._outputs[name] = Recorder()
        follow = node._service_clients["follow"] = FollowClient()
        node._service_clients["plan"] = PlanClient(planner)
        node._on_map(grid_message(corridor_grid(), Time(sec=1)))
        scan = LaserScan(angle_min=0.0, angle_increment=2 * math.pi / 240, range_min=0.12, range_max=3.5)
        scan.ranges = ranges.tolist()
        ours = []
        for stamp, pose, localized, confidence in steps:
            node.board.receive(other, node.get_clock().now().nanoseconds * 1e-9)
            node._on_scan(scan)
            estimate = LocalizedPose(localized=localized, confidence=confidence)
            estimate.header.stamp, estimate.header.frame_id = stamp_message(stamp), "map"
            estimate.pose.pose.position.x, estimate.pose.pose.position.y = pose[0], pose[1]
            estimate.pose.pose.orientation = quaternion(pose[2])
            node._on_pose(estimate)
            status = node._outputs["status"].messages[-1]
            limits = [m for m in node._outputs["speed_limit"].messages if m.header.stamp == estimate.header.stamp]
            limit = limits[-1].speed if limits and limits[-1].limited else None
            ours.append((status.mode, status.controller, limit))
    finally:
        node.destroy_node()
    assert any(limit == 0.0 for _, _, limit in library), library  # held
    assert loop.traffic.counters.replans_around >= 1 and len(handed) >= 2  # then planned around it
    for k, (a, b) in enumerate(zip(library, ours, strict=True)):
        assert a == b, f"observation {k}: library {a}, node {b}"
    assert len(handed) == len(follow.paths)
    for a, b in zip(handed, follow.paths, strict=True):
        assert np.allclose(a, b)
