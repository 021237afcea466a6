"""fleet_navigation: per robot the whole explore, localize, plan, go loop, every node in the robot's
namespace, copied from one description each; composed through ROS on a two-robot world: every robot's nodes
active in its namespace, each robot's filter localizing it, every robot driven."""

import math
from pathlib import Path

from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from support.ros import spin_until
from support.simulation import TWO_IN_THE_PILLAR_ROOM

from amr_bringup.composed import composed_stack
from amr_bringup.stack_config import load_bringup
from amr_interfaces.msg import LocalizedPose
from amr_maps.world import load_world
from amr_maps.world_symmetry import rotationally_symmetric
from amr_util.lean_executor import LeanExecutor
from amr_util.stamps import stamp_nanoseconds

RELIABLE = QoSProfile(depth=500, reliability=ReliabilityPolicy.RELIABLE)
ROBOTS = ("r1", "r2")
PER_ROBOT = ("planner", "path_follower", "wall_follower", "navigator", "particle_filter")
TIMEOUT = 50.0
"""s of wall clock for both robots to be localized (a loaded 2-core machine; about 10 s when quiet)."""


class Observer(Node):
    """Each robot's ground truth, estimates and commands."""

    def __init__(self, context) -> None:
        super().__init__("fleet_navigation_observer", context=context)
        self.truth = {r: {} for r in ROBOTS}
        self.poses = {r: [] for r in ROBOTS}
        self.commands = {r: [] for r in ROBOTS}
        self.keep = []
        for r in ROBOTS:
            self.keep += [
                self.create_subscription(Odometry, f"/{r}/ground_truth", lambda m, r=r: self._truth(r, m), RELIABLE),
                self.create_subscription(LocalizedPose, f"/{r}/pose", self.poses[r].append, RELIABLE),
                self.create_subscription(TwistStamped, f"/{r}/cmd_vel", self.commands[r].append, RELIABLE),
            ]

    def _truth(self, robot: str, message: Odometry) -> None:
        pose = message.pose.pose
        self.truth[robot][stamp_nanoseconds(message.header.stamp)] = (pose.position.x, pose.position.y)

    def localized_errors(self, robot: str) -> list[float]:
        """m, each localized estimate's distance from the true pose at its stamp."""
        errors = []
        for message in list(self.poses[robot]):
            truth = self.truth[robot].get(stamp_nanoseconds(message.header.stamp))
            if message.localized and truth is not None:
                position = message.pose.pose.position
                errors.append(math.hypot(position.x - truth[0], position.y - truth[1]))
        return errors


def test_the_stack_is_maze_navigation_per_robot_in_its_namespace():
    bringup = load_bringup("fleet_navigation").with_overrides({"world": "fleets/crossing.yaml"})
    names = [node.managed_name for node in bringup.nodes]
    robots = ("r1", "r2", "r3", "r4")
    assert sorted(names) == sorted(
        ["map_server", "simulator", "fleet_planner"] + [f"/{r}/{n}" for r in robots for n in PER_ROBOT]
    )
    assert bringup.node_startup_order[0] == "map_server" and bringup.node_startup_order[-1] == "simulator"
    maze = {node.name: node for node in load_bringup("maze_navigation").nodes}
    for node in bringup.nodes:
        if node.namespace:
            assert node.parameters["use_sim_time"] is True
            assert node.package == maze[node.name].package and node.executable == maze[node.name].executable
    nodes = {node.managed_name: node for node in bringup.nodes}
    assert nodes["/r1/particle_filter"].parameters["map_topic"] == "/map", "the one map"
    assert dict(nodes["/r1/planner"].remappings) == {"map": "/map"}, "the one map"
    assert nodes["/r3/navigator"].parameters["world_goal_topic"] == "goal", "the robot's own goal: /r3/goal"
    assert nodes["fleet_planner"].parameters["world"] == nodes["simulator"].parameters["world"], "one fleet"
    assert nodes["/r2/navigator"].parameters["coordination"] == "plan", "planned together by default"
    for node in bringup.nodes:  # nothing of a robot's leaves its namespace but the map
        for key, value in node.parameters.items():
            if isinstance(value, str) and value.startswith("/"):
                assert value == "/map", (node.managed_name, key, value)


def test_every_shipped_fleet_world_can_be_localized():
    """fleet_navigation's robots drive only once their filters say localized, and a filter must never say so
    where a rotation maps the walls onto themselves: a shipped fleet world that has one (crossing.yaml had a
    half turn) brings the stack up and leaves every robot exploring for ever."""
    worlds = sorted((Path(__file__).resolve().parents[2] / "config" / "worlds" / "fleets").glob("*.yaml"))
    assert worlds, "no shipped fleet worlds found"
    for path in worlds:
        world = load_world(path)
        assert world.fleet, f"{path.name}: a fleet world lists its robots"
        assert rotationally_symmetric(world) == "", f"{path.name}: symmetric under a rotation"


def test_two_robots_each_localize_and_drive_in_their_namespaces(ros_context, tmp_path):
    world = tmp_path / "two_in_the_pillar_room.yaml"
    world.write_text(TWO_IN_THE_PILLAR_ROOM)
    with composed_stack(
        ros_context,
        "fleet_navigation",
        arguments={"world": str(world)},
        parameters={"simulator.lockstep_resend_period": "0.5"},
    ) as (nodes, manager, _):
        assert set(nodes) == {"map_server", "simulator", "fleet_planner"} | {
            f"/{r}/{n}" for r in ROBOTS for n in PER_ROBOT
        }
        observer = Observer(ros_context)
        executor = LeanExecutor(context=ros_context)
        executor.add_node(observer)
        try:
            assert all(step.ok for step in manager.startup()), "fleet_navigation did not come up"
            assert {name: node.state_label for name, node in nodes.items()} == dict.fromkeys(nodes, "active")
            assert spin_until(executor, lambda: all(len(observer.localized_errors(r)) >= 5 for r in ROBOTS), TIMEOUT), {
                r: (len(observer.poses[r]), len(observer.localized_errors(r))) for r in ROBOTS
            }
            topics = {name for name, _ in observer.get_topic_names_and_types()}
        finally:
            executor.remove_node(observer)
            executor.shutdown()
        observer.destroy_node()

    for r in ROBOTS:
        errors = observer.localized_errors(r)
        assert max(errors) <= 0.10, f"{r}: localized {max(errors):.3f} m off the ground truth"
        assert any(abs(c.twist.linear.x) > 0.01 or abs(c.twist.angular.z) > 0.01 for c in observer.commands[r]), (
            f"{r}'s /cmd_vel was driven"
        )
        for topic in (
            "pose",
            "tf",
            "navigator/status",
            "particle_filter/status",
            "wall_follower/status",
            "path_follower/status",
            "cmd_vel",
            "scan",
            "odometry",
            "goal",
        ):
            assert f"/{r}/{topic}" in topics, (r, topic)
    for plain in ("/pose", "/tf", "/cmd_vel", "/scan", "/navigator/status", "/r1/map", "/r2/map"):
        assert plain not in topics, f"{plain}: nothing of a robot outside its namespace, one /map"
    assert {"/map", "/clock"} <= topics


def test_every_navigator_builds_its_traffic_costmap_as_its_planner_does():
    """The navigator's costmap.* (the traffic rules' costmap) agree with the planner's costmap parameters in
    the stack as started, by default and when the stack's robot_radius and safety_margin arguments change them;
    a -p on one node alone is refused (they are tied)."""
    import pytest

    from amr_bringup.stack_config import BringupError
    from amr_navigation.navigator_config import NavigatorConfig
    from amr_planning.planner import PlannerConfig

    shared = ("robot_radius", "safety_margin", "cost_weight", "cost_distance", "margin_cost")
    for arguments in ({}, {"robot_radius": "0.12", "safety_margin": "0.03"}):
        bringup = load_bringup("fleet_navigation").with_overrides({"world": "fleets/crossing.yaml", **arguments})
        nodes = {node.managed_name: node for node in bringup.nodes}
        for robot in ("r1", "r2", "r3", "r4"):
            planner = nodes[f"/{robot}/planner"].parameters
            navigator = {
                key: value for key, value in nodes[f"/{robot}/navigator"].parameters.items() if key != "use_sim_time"
            }
            planner_costmap = PlannerConfig.from_params(
                {k: v for k, v in planner.items() if k != "use_sim_time"}
            ).costmap
            navigator_costmap = NavigatorConfig.from_params(navigator).costmap
            for key in shared:
                assert getattr(navigator_costmap, key) == getattr(planner_costmap, key), (robot, key, arguments)
        if arguments:
            assert nodes["/r2/navigator"].parameters["costmap.robot_radius"] == 0.12
    with pytest.raises(BringupError, match="robot_radius"):
        load_bringup("fleet_navigation").with_overrides(
            {"world": "fleets/crossing.yaml"}, {"planner.robot_radius": "0.2"}
        )
