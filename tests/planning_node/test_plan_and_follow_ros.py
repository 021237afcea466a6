"""Plan + follow through ROS, lockstep: simulator, planner, path follower, and a relay standing in for the
localization (ground truth as a localized /pose); hard_maze's grid form gives /map exactly."""

from pathlib import Path

import numpy as np
import yaml
from amr_interfaces.msg import LocalizedPose, SimulatorStatus
from conftest import spin_until
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.node import Node

from amr_bringup.demo import config_file, params_file_args
from amr_control.path_follower_node import PathFollowerNode
from amr_planning.planner_node import PlannerNode
from amr_util.qos import LATCHED
from amr_simulation.simulator_node import SimulatorNode

ROOT = Path(__file__).resolve().parents[2]


def hard_maze_map() -> OccupancyGrid:
    grid = yaml.safe_load((ROOT / "config" / "worlds" / "hard_maze.yaml").read_text())["grid"]
    solid = np.array([[c == "#" for c in row] for row in reversed(grid["rows"])])
    data = np.kron(solid, np.ones((4, 4), dtype=bool)).astype(np.int8) * 100  # 0.025 m cells
    message = OccupancyGrid()
    message.header.frame_id = "map"
    message.info.resolution = 0.025
    message.info.height, message.info.width = data.shape
    message.info.origin.position.x, message.info.origin.position.y = grid["origin"]
    message.info.origin.orientation.w = 1.0
    message.data = data.ravel().tolist()
    return message


class Localization(Node):
    """Publishes the map, and each ground-truth pose as a localized /pose with the same stamp."""

    def __init__(self, context):
        super().__init__("fake_localization", context=context)
        self.map = self.create_publisher(OccupancyGrid, "map", LATCHED)
        self.pose = self.create_publisher(LocalizedPose, "pose", 10)
        self.create_subscription(Odometry, "ground_truth", self.relay, 10)
        self.status: list[SimulatorStatus] = []
        self.create_subscription(SimulatorStatus, "simulator/status", self.status.append, 10)

    def relay(self, truth: Odometry) -> None:
        message = LocalizedPose()
        message.header = truth.header
        message.pose = truth.pose
        message.localized = True
        self.pose.publish(message)


def test_the_robot_plans_and_follows_to_hard_maze_goal_without_touching_a_wall(ros_context, executor):
    simulator = SimulatorNode(context=ros_context, cli_args=params_file_args(
        config_file("amr_simulation", "simulator.yaml"), "world:=hard_maze.yaml"))
    planner = PlannerNode(context=ros_context)
    follower = PathFollowerNode(context=ros_context, cli_args=params_file_args(
        config_file("amr_control", "path_follower_sim.yaml")))
    localization = Localization(ros_context)
    for node in (simulator, planner, follower, localization):
        executor.add_node(node)
    for node in (planner, follower):
        assert node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    localization.map.publish(hard_maze_map())
    assert spin_until(executor, lambda: planner.planner is not None, 10.0)
    world = yaml.safe_load((ROOT / "config" / "worlds" / "hard_maze.yaml").read_text())
    goal = PoseStamped()  # the world's goal, as RViz's 2D Goal Pose would send it
    goal.pose.position.x, goal.pose.position.y = world["goal"][:2]
    goal_publisher = localization.create_publisher(PoseStamped, "goal_pose", 10)
    assert spin_until(executor, lambda: goal_publisher.get_subscription_count() > 0, 5.0)
    goal_publisher.publish(goal)
    assert spin_until(executor, lambda: planner._goal is not None, 5.0)
    assert simulator.try_transition(Transition.TRANSITION_CONFIGURE)
    assert simulator.try_transition(Transition.TRANSITION_ACTIVATE)

    def finished():
        return bool(localization.status) and (localization.status[-1].goal_reached or localization.status[-1].sim_time > 150.0)

    assert spin_until(executor, finished, 120.0), "the loop stalled"
    status = localization.status[-1]
    print(f"goal reached={status.goal_reached} at {status.sim_time:.1f} s, collisions {status.collisions}")
    assert status.goal_reached, f"goal not reached at t = {status.sim_time:.1f} s"
    assert status.collisions == 0
    assert status.sim_time < 120.0  # the wall follower alone needs about 365 s
    # lockstep: one command per observation once in charge (the first observations came before the path)
    assert follower.commands_sent >= round(status.sim_time / 0.05)
    for node in (follower, planner, simulator):
        node.shut_down_cleanly()
