"""The viewer node without a browser: what it takes from the graph, what a click sends, the parameters panel's
round trips (a live set taken, a structural one refused as the node says), and a port in use."""

import math
import socket
from types import SimpleNamespace

import numpy as np
import pytest
from geometry_msgs.msg import Pose as PoseMessage
from geometry_msgs.msg import PoseArray, PoseStamped, PoseWithCovarianceStamped, TransformStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import OccupancyGrid, Path
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty, Trigger
from support.ros import spin_for, spin_until
from tf2_msgs.msg import TFMessage

from amr_control.wall_follower_node import WallFollowerNode
from amr_interfaces.msg import LocalizedPose, SimulatorStatus
from amr_util.geometry import Pose2D
from amr_util.geometry import quaternion_from_yaw as quaternion_of
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_viewer.clicks import INITIAL_POSE
from amr_viewer.viewer_node import TF_STATIC, RobotLink, ViewerNode

TIMEOUT = 15.0
RNG = np.random.default_rng(5)


class FakeRobot(Node):
    """Publishes one of everything a stack publishes, and records what the viewer sends."""

    def __init__(self, context):
        super().__init__("fake_robot", context=context)
        self.map = self.create_publisher(OccupancyGrid, "map", LATCHED)
        self.tf = self.create_publisher(TFMessage, "tf", reliable(100))
        self.tf_static = self.create_publisher(TFMessage, "tf_static", TF_STATIC)
        self.scan = self.create_publisher(LaserScan, "scan", SENSOR_DATA)
        self.cloud = self.create_publisher(PoseArray, "particle_cloud", reliable(2))
        self.pose = self.create_publisher(LocalizedPose, "pose", reliable(10))
        self.path = self.create_publisher(Path, "path", LATCHED)
        self.status = self.create_publisher(SimulatorStatus, "simulator/status", reliable(10))
        self.goals, self.initial_poses = [], []
        self.create_subscription(PoseStamped, "goal_pose", self.goals.append, 10)
        self.create_subscription(PoseWithCovarianceStamped, "initialpose", self.initial_poses.append, 10)

    def publish_all(self, particles: int = 5000) -> None:
        grid = OccupancyGrid()
        grid.header.frame_id = "map"
        grid.info.width, grid.info.height, grid.info.resolution = 40, 30, 0.1
        grid.info.origin.position.x, grid.info.origin.position.y = -2.0, -1.5
        grid.info.origin.orientation.w = 1.0
        cells = np.zeros((30, 40), dtype=int)
        cells[0, :], cells[-1, :], cells[:, 0], cells[:, -1] = 100, 100, 100, 100
        grid.data = cells.ravel().tolist()
        self.map.publish(grid)
        self.tf_static.publish(TFMessage(transforms=[transform("base_footprint", "base_scan", -0.032, 0.0, 0.0)]))
        self.tf.publish(
            TFMessage(
                transforms=[
                    transform("odom", "base_footprint", 0.5, 0.25, 0.0),
                    transform("map", "odom", 0.1, 0.0, 0.0),
                ]
            )
        )
        scan = LaserScan()
        scan.header.frame_id = "base_scan"
        scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max = -math.pi, math.pi / 90, 0.12, 3.5
        scan.ranges = [1.0] * 180
        self.scan.publish(scan)
        cloud = PoseArray()
        cloud.header.frame_id = "map"
        for x, y in RNG.uniform(-1.5, 1.5, (particles, 2)):
            pose = PoseMessage()
            pose.position.x, pose.position.y, pose.orientation.w = float(x), float(y), 1.0
            cloud.poses.append(pose)
        self.cloud.publish(cloud)
        estimate = LocalizedPose()
        estimate.header.frame_id = "map"
        estimate.pose.pose.position.x, estimate.pose.pose.position.y = 0.6, 0.25
        estimate.pose.pose.orientation.w = 1.0
        covariance = [0.0] * 36
        covariance[0], covariance[7], covariance[35] = 0.01, 0.04, 0.1
        estimate.pose.covariance = covariance
        estimate.localized = True
        self.pose.publish(estimate)
        path = Path()
        path.header.frame_id = "map"
        for x in (0.6, 1.0, 1.4):
            point = PoseStamped()
            point.pose.position.x, point.pose.position.y = x, 0.25
            path.poses.append(point)
        self.path.publish(path)
        self.status.publish(
            SimulatorStatus(
                sim_time=3.5,
                steps=70,
                collisions=2,
                real_time_factor=12.0,
                localization_enabled=True,
                localized=True,
                position_error=0.012,
            )
        )


def transform(parent, child, x, y, yaw):
    message = TransformStamped()
    message.header.frame_id, message.child_frame_id = parent, child
    message.transform.translation.x, message.transform.translation.y = x, y
    q = message.transform.rotation
    q.x, q.y, q.z, q.w = quaternion_of(yaw)
    return message


@pytest.fixture
def viewer(ros_context):
    made = []

    def make(**parameters):
        node = ViewerNode(
            context=ros_context,
            parameter_overrides=[Parameter(name, value=value) for name, value in {"port": 0, **parameters}.items()],
        )
        made.append(node)
        return node

    yield make
    for node in made:
        node.destroy_node()


def test_it_takes_every_layer_of_a_robot_from_the_graph(ros_context, executor, viewer):
    node, robot = viewer(max_particles=800, discovery_period=0.2), FakeRobot(ros_context)
    executor.add_node(node)
    executor.add_node(robot)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE) and node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert node.url.startswith("http://127.0.0.1:")
    assert spin_until(executor, lambda: "" in node.robots, TIMEOUT), "the robot in the root namespace is found"
    link = node.robots[""]
    assert spin_until(
        executor, lambda: robot.cloud.get_subscription_count() and robot.scan.get_subscription_count(), TIMEOUT
    )
    robot.publish_all()
    state = link.state
    assert spin_until(
        executor,
        lambda: (
            state.particle_count
            and state.map is not None
            and state.status
            and state.estimate is not None
            and len(state.path)
            and state.scan is not None
        ),
        TIMEOUT,
    )
    assert (state.particle_count, len(state.particles)) == (5000, 800), "all counted, at most max_particles drawn"
    assert state.map.bounds == pytest.approx((-2.0, -1.5, 2.0, 1.5))
    assert state.robot_pose() == pytest.approx((0.6, 0.25, 0.0)), "map -> odom -> base_footprint"
    points = state.scan_in_map()
    assert len(points) == 180 and np.hypot(points[:, 0] - 0.568, points[:, 1] - 0.25) == pytest.approx(1.0)
    assert state.estimate.localized and state.estimate.covariance == pytest.approx((0.01, 0.0, 0.04))
    assert state.path[-1] == pytest.approx((1.4, 0.25))
    assert spin_until(executor, lambda: "12.0x real time" in node.panels.status.content, TIMEOUT)
    assert "collisions 2" in node.panels.status.content and "localized, error 1.2 cm" in node.panels.status.content


def click(x, y, height=5.0):
    """A viser click event whose ray hits the floor at (x, y)."""
    return SimpleNamespace(ray_origin=(x - 1.0, y + 2.0, height), ray_direction=(1.0 / height, -2.0 / height, -1.0))


def test_a_click_on_the_floor_sends_a_goal_or_a_pose_estimate(ros_context, executor, viewer):
    node, robot = viewer(), FakeRobot(ros_context)
    executor.add_node(node)
    executor.add_node(robot)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE) and node.try_transition(Transition.TRANSITION_ACTIVATE)
    node._on_floor_click(click(1.25, -0.5))  # no robot yet: heading 0
    assert spin_until(executor, lambda: robot.goals, TIMEOUT)
    goal = robot.goals[-1]
    assert goal.header.frame_id == "map"
    assert (goal.pose.position.x, goal.pose.position.y, goal.pose.orientation.w) == pytest.approx((1.25, -0.5, 1.0))
    assert "sent /goal_pose: (1.25, -0.50)" in node.panels.click_reply.content
    node.clicks.set_mode(INITIAL_POSE)
    node._on_floor_click(click(-0.75, 0.5))
    assert spin_until(executor, lambda: robot.initial_poses, TIMEOUT)
    estimate = robot.initial_poses[-1]
    assert (estimate.pose.pose.position.x, estimate.pose.pose.position.y) == pytest.approx((-0.75, 0.5))
    assert estimate.pose.covariance[0] == 0.25 and estimate.pose.covariance[35] > 0.0
    node._on_floor_click(SimpleNamespace(ray_origin=(0, 0, 1), ray_direction=(1, 0, 0)))  # the horizon
    node._on_floor_click(SimpleNamespace(ray_origin=(0, 0, 1), ray_direction=(0, 0, 1)))  # the sky
    executor.spin_once(timeout_sec=0.2)
    assert len(robot.initial_poses) == 1 and len(robot.goals) == 1


def test_the_parameters_panel_sets_live_values_and_shows_refusals(ros_context, executor, viewer):
    node = viewer()
    follower = WallFollowerNode(context=ros_context)
    executor.add_node(node)
    executor.add_node(follower)
    try:
        assert follower.try_transition(Transition.TRANSITION_CONFIGURE)
        assert node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
        reply = node.panels.parameter_reply
        assert spin_until(executor, lambda: node._parameters_client("/wall_follower").services_are_ready(), TIMEOUT)
        node._load_parameters("/wall_follower")
        assert spin_until(executor, lambda: "/wall_follower" in node._parameter_entries, TIMEOUT), reply.content
        entries = node._parameter_entries["/wall_follower"]
        assert entries["kp"].widget == "slider" and entries["kp"].value == follower.get_parameter("kp").value
        node._set_parameter("/wall_follower", entries["kp"], 3.0)
        assert spin_until(executor, lambda: follower.get_parameter("kp").value == 3.0, TIMEOUT)
        assert spin_until(executor, lambda: "kp = 3.0" in reply.content, TIMEOUT)
        node._set_parameter("/wall_follower", entries["dt"], 0.1)
        assert spin_until(executor, lambda: "refused" in reply.content, TIMEOUT)
        assert (
            reply.content == "/wall_follower refused dt = 0.1: dt is read-only while configured; cleanup, set, "
            "configure"
        )
        assert follower.get_parameter("dt").value == 0.05
        node._set_parameter("/wall_follower", entries["kp"], "fast")
        assert reply.content == "kp: 'fast' is not a number"
    finally:
        follower.destroy_node()


def test_a_port_in_use_fails_configure_naming_it(ros_context, viewer):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        node = viewer(port=port)
        assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert node.server is None and node.state_label == "unconfigured"


def test_cleanup_stops_serving_and_a_second_configure_serves_again(ros_context, executor, viewer):
    node = viewer(discovery_period=0.2)
    executor.add_node(node)
    for _ in range(2):
        assert node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
        port = node.server.get_port()
        with socket.create_connection(("127.0.0.1", port), timeout=5.0):
            pass  # the page is served
        spin_for(executor, 0.5)  # a few discoveries and draws
        assert node.try_transition(Transition.TRANSITION_DEACTIVATE)
        assert node.try_transition(Transition.TRANSITION_CLEANUP)
        assert node.server is None and not list(node.clients) and node.robots == {}
        with pytest.raises(OSError):
            socket.create_connection(("127.0.0.1", port), timeout=1.0).close()


class FakeControls(Node):
    """A simulator's four controls and a localizer's ~/reinitialize_global_localization, counting the calls."""

    def __init__(self, context):
        super().__init__("fake_controls", context=context)
        self.calls: list[str] = []

        def answer(name):
            def callback(request, response):
                self.calls.append(name)
                response.success, response.message = True, f"{name} done"
                return response

            return callback

        for name in ("pause", "resume", "step", "reset"):
            self.create_service(Trigger, f"/simulator/{name}", answer(name))
        self.create_service(
            Empty,
            "/particle_filter/reinitialize_global_localization",
            lambda request, response: self.calls.append("relocalize") or response,
        )


def test_reset_restarts_global_localization_on_every_localizer_first(ros_context, executor, viewer):
    node, controls = viewer(), FakeControls(ros_context)
    executor.add_node(node)
    executor.add_node(controls)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE) and node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(
        executor,
        lambda: (
            node.simulators
            and node.localizers
            and all(
                client.service_is_ready()
                for client in [*node.simulators["/simulator"].values(), *node.localizers.values()]
            )
        ),
        TIMEOUT,
    ), "the simulator and the localizer found in the graph"
    node._control("pause")
    assert spin_until(executor, lambda: "pause done" in node.panels.simulation_reply.content, TIMEOUT)
    node._control("reset")
    assert spin_until(executor, lambda: "reset" in controls.calls, TIMEOUT)
    assert controls.calls == ["pause", "relocalize", "reset"], "the localizer first: it judges the reset afresh"
    assert spin_until(executor, lambda: "reset done" in node.panels.simulation_reply.content, TIMEOUT)
    assert (
        node.panels.simulation_reply.content
        == "/simulator: reset done; global localization restarted on /particle_filter"
    )


FLEET_WORLD = """\
name: two_in_a_room
wall_thickness: 0.05
walls: [[-2.0, -1.5, 2.0, -1.5], [2.0, -1.5, 2.0, 1.5], [2.0, 1.5, -2.0, 1.5], [-2.0, 1.5, -2.0, -1.5]]
robots:
  - {name: r1, start: [-1.0, -0.5, 0.0]}
  - {name: r2, start: [1.0, 0.5, 3.14159265358979]}
"""


def test_it_draws_every_robot_of_a_fleet_in_its_namespace(ros_context, executor, viewer, tmp_path):
    """fleet_sim (docs/fleet.md): one robot per namespace, each with its own tree, scan and simulator status."""
    from amr_bringup.composed import composed_stack

    world = tmp_path / "two.yaml"
    world.write_text(FLEET_WORLD)
    with composed_stack(ros_context, "fleet_sim", arguments={"world": str(world)}) as (_, manager, _):
        node = viewer(discovery_period=0.2)
        executor.add_node(node)
        assert node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
        assert all(step.ok for step in manager.startup()), "fleet_sim did not come up"
        assert spin_until(executor, lambda: {"/r1", "/r2"} <= set(node.robots), TIMEOUT), sorted(node.robots)
        assert "" not in node.robots, "nothing of a robot outside its namespace"
        states = {name: node.robots[name].state for name in ("/r1", "/r2")}

        def drawn() -> bool:
            for link in node.robots.values():
                link.decode()
            return all(
                s.status.get("steps", 0) > 5 and s.robot_pose() is not None and len(s.scan_in_map()) > 0
                for s in states.values()
            )  # the scan placed: its frame's static transform may come last

        assert spin_until(executor, drawn, TIMEOUT)
        executor.remove_node(node)
    assert states["/r1"].robot_pose().x < 0.0 < states["/r2"].robot_pose().x, "each robot where its tree puts it"


def test_a_fleet_robot_found_before_its_own_tree_takes_it_when_it_appears(ros_context, viewer):
    node = viewer()
    link = RobotLink(node, "/r1", {"/r1/particle_cloud", "/tf"})  # its filter up, its simulator not yet
    assert (link.topics["tf"], link.topics["map"], link.topics["simulator/status"]) == (
        "/tf",
        "/map",
        "/r1/simulator/status",
    )
    assert link.topics["particle_cloud"] == "/r1/particle_cloud"
    link.state.tree.set("odom", "base_footprint", Pose2D(1.0, 0.0, 0.0))  # the root's tree: not this robot's
    assert sorted(link.refresh({"/r1/particle_cloud", "/r1/tf", "/r1/status", "/tf"})) == ["simulator/status", "tf"]
    assert (link.topics["tf"], link.topics["simulator/status"]) == ("/r1/tf", "/r1/status")
    assert not link.state.tree.has("base_footprint"), "the root's transforms forgotten"
    assert link.refresh(set()) == [] and link.topics["tf"] == "/r1/tf", "kept once found"
    assert len(link.subscriptions) == len(RobotLink.RAW_TOPICS) + 1
    assert RobotLink(node, "", set()).topics["tf"] == "/tf"
