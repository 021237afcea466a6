"""Explore, plan, follow through ROS, lockstep: simulator, map_server, planner, both controllers `navigated`, the
navigator, and a relay standing in for the localization (the ground truth as /pose, localized after the first
seconds); hard_maze at 0.025 m gives /map exactly. Exactly one /cmd_vel answers each observation, across the
hand-over; goals are taken at any time, an unreachable one stops the robot and the status says why."""

import math
from collections import defaultdict
from pathlib import Path

import yaml
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.time import Time
from support.ros import spin_for, spin_until

from amr_bringup.demo import config_file, params_file_args
from amr_control.path_follower_node import PathFollowerNode
from amr_control.wall_follower_node import WallFollowerNode
from amr_interfaces.msg import LocalizedPose, NavigatorStatus, SimulatorStatus
from amr_maps.map_server_node import MapServerNode
from amr_navigation.navigator_node import NavigatorNode
from amr_planning.planner_node import PlannerNode
from amr_simulation.simulator_node import SimulatorNode

ROOT = Path(__file__).resolve().parents[2]
EXPLORE_FOR = 2.0  # s of simulated time the stand-in localization says not localized (the wall follower drives)


class Localization(Node):
    """Each ground-truth pose as /pose with the same stamp; localized after EXPLORE_FOR seconds."""

    def __init__(self, context):
        super().__init__("fake_localization", context=context)
        self.pose = self.create_publisher(LocalizedPose, "pose", 10)
        self.create_subscription(Odometry, "ground_truth", self.relay, 10)
        self.status: list[SimulatorStatus] = []
        self.create_subscription(SimulatorStatus, "simulator/status", self.status.append, 10)
        self.decisions: dict[int, NavigatorStatus] = {}
        self.create_subscription(NavigatorStatus, "navigator/status", self.on_decision, 100)
        self.goal = self.create_publisher(PoseStamped, "goal_pose", 10)
        self.truth = None

    def relay(self, truth: Odometry) -> None:
        self.truth = truth.pose.pose.position
        message = LocalizedPose()
        message.header = truth.header
        message.pose = truth.pose
        message.localized = Time.from_msg(truth.header.stamp).nanoseconds * 1e-9 >= EXPLORE_FOR
        self.pose.publish(message)

    def on_decision(self, status: NavigatorStatus) -> None:
        self.decisions[Time.from_msg(status.header.stamp).nanoseconds] = status  # the last decision per observation

    @property
    def last(self) -> NavigatorStatus | None:
        return self.decisions[max(self.decisions)] if self.decisions else None

    def send_goal(self, x: float, y: float) -> None:
        goal = PoseStamped()
        goal.header.frame_id = "map"
        goal.pose.position.x, goal.pose.position.y = x, y
        self.goal.publish(goal)


def answered_observations(*controllers) -> dict[int, list[str]]:
    """Spy on the controllers' _compute: which node answered which observation (by the scan's stamp)."""
    answers = defaultdict(list)
    for node in controllers:
        original, name = node._compute, node.get_name()

        def compute(first, scan, original=original, name=name):
            answers[Time.from_msg(scan.header.stamp).nanoseconds].append(name)
            return original(first, scan)

        node._compute = compute
    return answers


def test_the_navigator_hands_over_plans_follows_takes_new_goals_and_stops_for_an_unreachable_one(ros_context, executor):
    simulator = SimulatorNode(
        context=ros_context,
        cli_args=params_file_args(
            config_file("amr_simulation", "simulator.yaml"), "world:=hard_maze.yaml", "stop_at_goal:=false"
        ),
    )
    map_server = MapServerNode(
        context=ros_context,
        parameter_overrides=[Parameter("world", value="hard_maze.yaml"), Parameter("resolution", value=0.025)],
    )
    planner = PlannerNode(context=ros_context)
    follower = PathFollowerNode(
        context=ros_context,
        cli_args=params_file_args(config_file("amr_control", "path_follower_sim.yaml"), "navigated:=true"),
    )
    wall = WallFollowerNode(
        context=ros_context,
        cli_args=params_file_args(config_file("amr_control", "wall_follower_sim.yaml"), "navigated:=true"),
    )
    navigator = NavigatorNode(
        context=ros_context,
        cli_args=params_file_args(config_file("amr_navigation", "navigator.yaml"), "world_goal_topic:=/simulator/goal"),
    )
    localization = Localization(ros_context)
    answers = answered_observations(follower, wall)
    for node in (simulator, map_server, planner, follower, wall, navigator, localization):
        executor.add_node(node)
    for node in (map_server, planner, follower, wall, navigator):
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), getattr(node, "configure_error", "")
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: planner.planner is not None, 10.0)
    assert simulator.try_transition(Transition.TRANSITION_CONFIGURE)
    assert simulator.try_transition(Transition.TRANSITION_ACTIVATE)
    world_goal = yaml.safe_load((ROOT / "config" / "worlds" / "hard_maze.yaml").read_text())["goal"][:2]

    def status():
        return localization.status[-1] if localization.status else None

    def finished():
        return status() is not None and (status().goal_reached or status().sim_time > 150.0)

    assert spin_until(executor, finished, 120.0), "the loop stalled"
    reached_at = status()
    print(f"goal reached={reached_at.goal_reached} at {reached_at.sim_time:.1f} s, collisions {reached_at.collisions}")
    assert reached_at.goal_reached, f"goal not reached at t = {reached_at.sim_time:.1f} s"
    assert reached_at.collisions == 0
    assert reached_at.sim_time < 120.0  # the wall follower alone needs about 365 s
    assert spin_until(executor, lambda: localization.last.mode == "REACHED", 10.0)
    assert navigator.navigator.goal == tuple(world_goal)  # the world's goal, from the simulator's latched ~/goal

    # a goal after arrival: planned, followed (the simulator judged its own goal but froze nothing)
    localization.send_goal(1.15, 1.75)
    assert spin_until(executor, lambda: localization.last.mode == "REACHED" and localization.last.goal.x == 1.15, 60.0)
    assert math.hypot(localization.truth.x - 1.15, localization.truth.y - 1.75) < 0.1

    # a goal inside a wall: the robot stops, the status says why, nothing more is sent
    localization.send_goal(2.0, 2.0)
    assert spin_until(executor, lambda: localization.last.mode == "NO_PATH", 10.0)
    held = localization.last
    assert held.controller == "" and "no path to (2.00, 2.00)" in held.reason and "goal" in held.reason
    steps = status().steps
    spin_for(executor, 1.5)
    assert status().steps == steps, "the robot moved on towards an old goal"

    # and a reachable one again: the held observation is given to the path follower
    localization.send_goal(1.75, 1.35)
    assert spin_until(executor, lambda: localization.last.mode == "REACHED" and localization.last.goal.y == 1.35, 60.0)
    assert status().collisions == 0

    # exactly one command per observation: the one the navigator's last decision named, nobody's where it named none
    spin_for(executor, 0.3)
    newest = max(localization.decisions)
    for stamp, decision in localization.decisions.items():
        expected = [decision.controller] if decision.controller else []
        if stamp != newest or not expected:
            assert answers.get(stamp, []) == expected, (stamp * 1e-9, decision.mode, answers.get(stamp))
    explored = [s for s, d in localization.decisions.items() if d.controller == "wall_follower"]
    followed = [s for s, d in localization.decisions.items() if d.controller == "path_follower"]
    assert explored and followed and max(explored) < min(followed)  # the hand-over, at EXPLORE_FOR
    assert not set(answers) - set(localization.decisions), "a controller answered an observation nobody gave it"
    for node in (navigator, wall, follower, planner, map_server, simulator):
        node.shut_down_cleanly()
