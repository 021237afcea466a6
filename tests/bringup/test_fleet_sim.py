"""fleet_sim: one wall follower per robot of the world, in the robot's namespace, from one description;
through ROS, composed: every topic and frame namespaced, both robots move, each sees the other in its scan."""

import math
from dataclasses import replace

import pytest
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from support.ros import spin_until
from tf2_msgs.msg import TFMessage

from amr_bringup.composed import composed_stack
from amr_bringup.stack_config import BringupError, load_bringup, parse_bringup, robot_nodes
from amr_interfaces.msg import SimulatorStatus
from amr_maps.world import RobotSpec
from amr_util.lean_executor import LeanExecutor
from amr_util.qos import LATCHED
from amr_util.stamps import stamp_nanoseconds

RELIABLE = QoSProfile(depth=500, reliability=ReliabilityPolicy.RELIABLE)
ROBOTS = ("r1", "r2")
RADIUS, LIDAR_X = 0.105, -0.032
MOVED = 0.3
"""m each robot must travel."""
TIMEOUT = 90.0
"""s for the run (a loaded 2-core machine)."""
TWO = """\
name: two_in_a_room
wall_thickness: 0.05
walls:
  - [-2.0, -1.5, 2.0, -1.5]
  - [2.0, -1.5, 2.0, 1.5]
  - [2.0, 1.5, -2.0, 1.5]
  - [-2.0, 1.5, -2.0, -1.5]
robots:
  - name: r1
    start: [-1.0, -0.5, 0.0]
  - name: r2
    start: [1.0, 0.5, 3.14159265358979]
"""


class Observer(Node):
    """Records each robot's ground truth, scans, status, commands and transforms."""

    def __init__(self, context) -> None:
        super().__init__("fleet_observer", context=context)
        self.truth = {r: {} for r in ROBOTS}  # stamp ns -> (x, y, theta)
        self.scans = {r: [] for r in ROBOTS}
        self.statuses = {r: [] for r in ROBOTS}
        self.commands = {r: [] for r in ROBOTS}
        self.tf = {topic: [] for r in ROBOTS for topic in (f"/{r}/tf", f"/{r}/tf_static")}
        self.keep = []
        for r in ROBOTS:
            self.keep += [
                self.create_subscription(Odometry, f"/{r}/ground_truth", lambda m, r=r: self._truth(r, m), RELIABLE),
                self.create_subscription(LaserScan, f"/{r}/scan", self.scans[r].append, qos_profile_sensor_data),
                self.create_subscription(SimulatorStatus, f"/{r}/status", self.statuses[r].append, RELIABLE),
                self.create_subscription(TwistStamped, f"/{r}/cmd_vel", self.commands[r].append, RELIABLE),
                self.create_subscription(TFMessage, f"/{r}/tf", self.tf[f"/{r}/tf"].append, RELIABLE),
                self.create_subscription(TFMessage, f"/{r}/tf_static", self.tf[f"/{r}/tf_static"].append, LATCHED),
            ]

    def _truth(self, robot: str, message: Odometry) -> None:
        pose = message.pose.pose
        self.truth[robot][stamp_nanoseconds(message.header.stamp)] = (
            pose.position.x,
            pose.position.y,
            2.0 * math.atan2(pose.orientation.z, pose.orientation.w),
        )

    def moved(self, robot: str) -> float:
        poses = list(self.truth[robot].values())
        return math.dist(poses[0][:2], poses[-1][:2]) if poses else 0.0

    def frames(self, topic: str) -> set[tuple[str, str]]:
        return {(t.header.frame_id, t.child_frame_id) for m in self.tf[topic] for t in m.transforms}


def expected_range_to(observer_pose, other_pose, scan: LaserScan) -> tuple[int, float]:
    """The beam pointing at the other robot's centre and the range it should read (the disc's near side)."""
    x, y, theta = observer_pose
    sx, sy = x + LIDAR_X * math.cos(theta), y + LIDAR_X * math.sin(theta)
    dx, dy = other_pose[0] - sx, other_pose[1] - sy
    bearing = math.atan2(dy, dx) - theta - scan.angle_min
    beam = round(bearing / scan.angle_increment) % len(scan.ranges)
    return beam, math.hypot(dx, dy) - RADIUS


def test_two_robots_each_under_its_namespace_drive_and_see_each_other(ros_context, tmp_path):
    world = tmp_path / "two_in_a_room.yaml"
    world.write_text(TWO)
    with composed_stack(
        ros_context,
        "fleet_sim",
        arguments={"world": str(world)},
        parameters={"simulator.lockstep_resend_period": "0.5"},
    ) as (nodes, manager, _):
        assert set(nodes) == {"map_server", "simulator", "/r1/wall_follower", "/r2/wall_follower"}
        assert manager.get_parameter("node_startup_order").value == [
            "map_server",
            "/r1/wall_follower",
            "/r2/wall_follower",
            "simulator",
        ]
        observer = Observer(ros_context)
        executor = LeanExecutor(context=ros_context)
        executor.add_node(observer)
        try:
            assert all(step.ok for step in manager.startup()), "fleet_sim did not come up"
            assert spin_until(executor, lambda: all(observer.moved(r) > MOVED for r in ROBOTS), TIMEOUT), (
                f"moved {[observer.moved(r) for r in ROBOTS]} m"
            )
            assert spin_until(executor, lambda: all(observer.tf[f"/{r}/tf_static"] for r in ROBOTS), 10.0)
            topics = {name for name, _ in observer.get_topic_names_and_types()}
        finally:
            executor.remove_node(observer)
            executor.shutdown()
        observer.destroy_node()

    for r in ROBOTS:
        for topic in (
            "cmd_vel",
            "scan",
            "odom",
            "odometry",
            "ground_truth",
            "status",
            "tf",
            "tf_static",
            "wall_follower/status",
        ):
            assert f"/{r}/{topic}" in topics, (r, topic)
    for plain in (
        "/cmd_vel",
        "/scan",
        "/odom",
        "/odometry",
        "/ground_truth",
        "/tf",
        "/tf_static",
        "/simulator/status",
        "/wall_follower/status",
    ):
        assert plain not in topics, f"{plain}: nothing of a robot outside its namespace"
    assert {"/clock", "/map"} <= topics

    for r, other in (("r1", "r2"), ("r2", "r1")):
        assert observer.commands[r], f"{r}'s wall follower drove it"
        assert {s.robot for s in observer.statuses[r]} == {r}
        assert observer.frames(f"/{r}/tf") == {("odom", "base_footprint")}
        assert observer.frames(f"/{r}/tf_static") == {("base_footprint", "base_scan")}
        assert {s.header.frame_id for s in observer.scans[r]} == {"base_scan"}
        # every scan taken with the other within range shows its disc where the ground truth puts it
        seen = 0
        for scan in observer.scans[r]:
            stamp = stamp_nanoseconds(scan.header.stamp)
            if stamp not in observer.truth[r] or stamp not in observer.truth[other]:
                continue
            beam, expected = expected_range_to(observer.truth[r][stamp], observer.truth[other][stamp], scan)
            if expected < scan.range_max - 0.2:
                assert scan.ranges[beam] == pytest.approx(expected, abs=0.05), (r, stamp, beam)
                seen += 1
        assert seen >= 10, f"{r} saw {other} in {seen} scans only"


def test_a_one_robot_world_runs_the_wall_follower_as_maze_sim_does():
    fleet = load_bringup("fleet_sim").with_overrides({"world": "open_room.yaml"})
    maze = load_bringup("maze_sim").with_overrides({"world": "open_room.yaml"})
    assert (
        [n.managed_name for n in fleet.nodes]
        == [n.managed_name for n in maze.nodes]
        == ["map_server", "simulator", "wall_follower"]
    )
    assert fleet.node_startup_order == maze.node_startup_order
    follower = {n.name: n for n in fleet.nodes}["wall_follower"]
    assert replace(follower, per_robot=False) == {n.name: n for n in maze.nodes}["wall_follower"]
    assert follower.namespace == "" and follower.parameter_files == ("wall_follower_sim.yaml",)


def test_robot_copies_are_namespaced_and_carry_the_file_values_inline():
    template = {n.name: n for n in load_bringup("fleet_sim").nodes}["wall_follower"]
    assert template.per_robot
    copies = robot_nodes(
        replace(template, parameters={"use_sim_time": True, "preferred_wall": "left"}),
        [RobotSpec("a", (0, 0, 0), None), RobotSpec("b", (1, 0, 0), None)],
    )
    assert [c.managed_name for c in copies] == ["/a/wall_follower", "/b/wall_follower"]
    for copy in copies:
        assert not copy.per_robot and copy.parameter_files == ()
        assert copy.parameters["preferred_wall"] == "left", "inline parameters win over the file's"
        assert copy.parameters["simulation"] is True, "the file's values reach the namespaced node"
        assert "-r" in copy.ros_arguments() and "__ns:=" + copy.namespace in copy.ros_arguments()


@pytest.mark.parametrize(
    "document, message",
    [
        ({"nodes": [{"name": "a", "package": "p", "executable": "e", "per_robot": True}]}, "robots_from: required"),
        (
            {"nodes": [{"name": "a", "package": "p", "executable": "e"}], "robots_from": "a.world"},
            "robots_from: no node has per_robot",
        ),
        (
            {
                "nodes": [
                    {"name": "a", "package": "p", "executable": "e", "per_robot": True},
                    {"name": "s", "package": "p", "executable": "e"},
                ],
                "robots_from": "a.world",
            },
            r"robots_from: 'a.world' is not <node>.<parameter> of a node in \['s'\]",
        ),
        (
            {"nodes": [{"name": "a", "package": "p", "executable": "e", "per_robot": "yes"}]},
            r"nodes\[0\].per_robot: must be true or false",
        ),
    ],
)
def test_bad_per_robot_sections_are_refused_naming_the_key(document, message, tmp_path):
    with pytest.raises(BringupError, match=message):
        parse_bringup(document, tmp_path / "s.yaml")


def test_a_world_that_does_not_load_is_named_with_the_key():
    with pytest.raises(BringupError, match=r"fleet_sim.yaml: robots_from: simulator.world = 'nowhere.yaml': "):
        load_bringup("fleet_sim").with_overrides({"world": "nowhere.yaml"})
