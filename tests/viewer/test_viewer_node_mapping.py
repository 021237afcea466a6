"""The viewer node with a SLAM stack's topics, no browser: each new /map, pose graph and frontiers message becomes
the robot's state (a growing map replaces the last); a message with a NaN or in a wrong frame is skipped, logged
once and counted; every robot namespace has its own graph and frontiers, found by type under another node name."""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from geometry_msgs.msg import Point, Pose2D
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import OccupancyGrid
from rclpy.node import Node
from rclpy.parameter import Parameter
from support.ros import spin_until

from amr_interfaces.msg import Frontiers, LocalizedPose, PoseGraph
from amr_util.geometry import Pose2D as Pose
from amr_util.qos import LATCHED, reliable
from amr_viewer.cdr import StampedTransform
from amr_viewer.state import map_image
from amr_viewer.viewer_node import RobotLink, ViewerNode

TIMEOUT = 15.0


class FakeSlam(Node):
    """What amr_mapping's slam and explorer publish in a namespace: /map (growing), slam/graph, explorer/frontiers
    (all three latched, as theirs), and /pose (which makes the namespace a robot)."""

    def __init__(self, context, namespace: str = "/", slam: str = "slam", explorer: str = "explorer"):
        super().__init__("fake_slam", namespace=namespace, context=context)
        self.map = self.create_publisher(OccupancyGrid, "map", LATCHED)
        self.graph = self.create_publisher(PoseGraph, f"{slam}/graph", LATCHED)
        self.frontiers = self.create_publisher(Frontiers, f"{explorer}/frontiers", LATCHED)
        self.pose = self.create_publisher(LocalizedPose, "pose", reliable(10))
        self.pose.publish(LocalizedPose())

    def publish_map(self, width: int, height: int, frame: str = "map", x: float = -1.0) -> None:
        grid = OccupancyGrid()
        grid.header.frame_id = frame
        grid.info.width, grid.info.height, grid.info.resolution = width, height, 0.05
        grid.info.origin.position.x, grid.info.origin.position.y = x, -1.0
        grid.info.origin.orientation.w = 1.0
        grid.data = [-1] * (width * height)
        self.map.publish(grid)

    def publish_graph(self, count: int, closures: int = 0, frame: str = "map", offset: float = 0.0) -> None:
        message = PoseGraph()
        message.header.frame_id = frame
        message.poses = [Pose2D(x=offset + 0.2 * k, y=0.0, theta=0.0) for k in range(count)]
        pairs = [(k, k + 1, False) for k in range(count - 1)] + [(count - 1, k, True) for k in range(closures)]
        message.edge_from = [a for a, _, _ in pairs]
        message.edge_to = [b for _, b, _ in pairs]
        message.loop_closure = [flag for _, _, flag in pairs]
        self.graph.publish(message)

    def publish_frontiers(self, centroids, chosen: int, frame: str = "map", state: str = "exploring") -> None:
        message = Frontiers(chosen=chosen, blacklisted=1, state=state)
        message.header.frame_id = frame
        message.centroids = [Point(x=x, y=y) for x, y in centroids]
        message.sizes = [10] * len(centroids)
        self.frontiers.publish(message)


class Warnings:
    """The node's logger, with every warning kept."""

    def __init__(self, logger) -> None:
        self.logger, self.texts = logger, []

    def warning(self, text, **kwargs) -> None:
        self.texts.append(text)
        self.logger.warning(text, **kwargs)

    def __getattr__(self, name):
        return getattr(self.logger, name)


@pytest.fixture
def viewer(ros_context, executor, monkeypatch):
    node = ViewerNode(
        context=ros_context,
        parameter_overrides=[Parameter("port", value=0), Parameter("discovery_period", value=0.2)],
    )
    warnings = Warnings(node.get_logger())
    monkeypatch.setattr(node, "get_logger", lambda: warnings)
    executor.add_node(node)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE) and node.try_transition(Transition.TRANSITION_ACTIVATE)
    yield node, warnings
    node.destroy_node()


def found(executor, node, slam: FakeSlam, namespace: str):
    """The robot's link once the viewer subscribes to the slam node's topics."""
    assert spin_until(
        executor,
        lambda: (
            namespace in node.robots
            and slam.graph.get_subscription_count() > 0
            and slam.frontiers.get_subscription_count() > 0
            and slam.map.get_subscription_count() > 0
        ),
        TIMEOUT,
    ), f"robot {namespace or '/'} and its slam topics found: {sorted(node.robots)}"
    return node.robots[namespace]


def test_each_new_map_graph_and_frontiers_is_the_robots_state(ros_context, executor, viewer):
    node, warnings = viewer
    slam = FakeSlam(ros_context)
    executor.add_node(slam)
    state = found(executor, node, slam, "").state

    slam.publish_map(40, 40)
    assert spin_until(executor, lambda: state.map is not None, TIMEOUT)
    assert state.map.bounds == pytest.approx((-1.0, -1.0, 1.0, 1.0))
    slam.publish_map(80, 60, frame="/map", x=-2.0)  # the map grew: the new one replaces it
    assert spin_until(executor, lambda: state.map.bounds[0] < -1.5, TIMEOUT)
    assert state.map.bounds == pytest.approx((-2.0, -1.0, 2.0, 2.0)) and state.versions["map"] == 2

    slam.publish_graph(5)
    assert spin_until(executor, lambda: state.graph is not None, TIMEOUT)
    assert (len(state.graph.poses), len(state.graph.edges), state.graph.loop_closures) == (5, 4, 0)
    slam.publish_graph(9, closures=2)
    assert spin_until(executor, lambda: len(state.graph.poses) == 9, TIMEOUT)
    assert state.graph.loop_closures == 2 and state.graph.segments(True)[0] == pytest.approx(
        np.array([[1.6, 0.0], [0.0, 0.0]])
    )

    slam.publish_frontiers([(0.5, 0.5), (1.5, -0.5)], chosen=1)
    assert spin_until(executor, lambda: state.frontiers is not None, TIMEOUT)
    assert state.frontiers.chosen_centroid == pytest.approx((1.5, -0.5)) and state.frontiers.state == "exploring"
    slam.publish_frontiers([], chosen=-1, state="done")
    assert spin_until(executor, lambda: state.frontiers.state == "done", TIMEOUT)
    assert len(state.frontiers.centroids) == 0 and state.frontiers.chosen_centroid is None
    assert spin_until(executor, lambda: "explorer done: 0 frontiers, 1 given up" in node.panels.status.content, TIMEOUT)
    assert "graph 9 nodes, 10 edges, 2 loop closures" in node.panels.status.content

    # bad messages: skipped, the state kept, each reason logged once and counted
    versions = dict(state.versions)
    graph, frontiers, image = state.graph, state.frontiers, state.map
    for count in (1, 2):
        message = PoseGraph(poses=[Pose2D(x=0.0, y=math.nan, theta=0.0)])
        message.header.frame_id = "map"
        slam.graph.publish(message)
        assert spin_until(executor, lambda count=count: state.skipped["graph"] == count, TIMEOUT)
    slam.publish_frontiers([(0.0, 0.0)], chosen=0, frame="odom")
    assert spin_until(executor, lambda: state.skipped["frontiers"] == 1, TIMEOUT)
    slam.publish_map(10, 10, frame="base_footprint")
    assert spin_until(executor, lambda: state.skipped["map"] == 1, TIMEOUT)
    assert state.graph is graph and state.frontiers is frontiers and state.map is image
    assert all(state.versions[layer] == versions[layer] for layer in ("map", "graph", "frontiers"))
    skipped = [text for text in warnings.texts if "skipped" in text]
    assert len(skipped) == 3, skipped
    assert "pose graph node 0 of 1 is (0.0, nan, 0.0): not finite" in skipped[0]
    assert "frontiers in frame 'odom', not 'map'" in skipped[1]
    assert "map in frame 'base_footprint'" in skipped[2]
    assert spin_until(executor, lambda: "2 graph messages not drawn" in node.panels.status.content, TIMEOUT)


def test_every_robot_namespace_has_its_own_graph_and_frontiers(ros_context, executor, viewer):
    node, _ = viewer
    first = FakeSlam(ros_context, "/r1")
    second = FakeSlam(ros_context, "/r2", slam="mapper", explorer="explore")  # other node names: found by type
    for slam in (first, second):
        executor.add_node(slam)
    links = {namespace: found(executor, node, slam, namespace) for namespace, slam in (("/r1", first), ("/r2", second))}
    assert links["/r2"].topics["slam/graph"] == "/r2/mapper/graph"
    assert links["/r2"].topics["explorer/frontiers"] == "/r2/explore/frontiers"
    first.publish_graph(3, offset=-5.0)
    second.publish_graph(6, closures=1, offset=5.0)
    first.publish_frontiers([(-4.0, 1.0)], chosen=0, frame="r1/map")
    second.publish_frontiers([(4.0, 1.0), (6.0, 1.0)], chosen=-1)
    states = {namespace: link.state for namespace, link in links.items()}
    assert spin_until(
        executor, lambda: all(s.graph is not None and s.frontiers is not None for s in states.values()), TIMEOUT
    )
    assert len(states["/r1"].graph.poses) == 3 and states["/r1"].graph.poses[0, 0] == pytest.approx(-5.0)
    assert len(states["/r2"].graph.poses) == 6 and states["/r2"].graph.loop_closures == 1
    assert states["/r1"].frontiers.chosen_centroid == pytest.approx((-4.0, 1.0)), "its namespace's map frame"
    assert np.allclose(states["/r2"].frontiers.centroids[:, 0], (4.0, 6.0))
    assert "" not in node.robots


def test_the_top_view_follows_a_growing_map_until_the_user_moves_the_camera(ros_context, viewer):
    node, _ = viewer
    link = node.robots[""] = RobotLink(node, "", set())
    state = link.state
    client = SimpleNamespace(
        client_id=7, camera=SimpleNamespace(aspect=1.6, image_width=1024, fov=1.0, position=None, look_at=None)
    )

    def grow(cells: int) -> None:
        state.on_map(map_image(cells, cells, 0.05, Pose(-1.0, -1.0, 0.0), [-1] * cells * cells))

    state.on_transforms([StampedTransform("odom", "base_footprint", 0.0, Pose(0.0, 0.0, 0.0))])
    node._frame(client, "top")  # no map yet: the robot's surroundings
    state.on_transforms([StampedTransform("odom", "base_footprint", 0.0, Pose(5.0, 0.0, 0.0))])
    assert not node._follow_growth(client), "without a map the view stays where it was put"
    grow(40)
    node._frame(client, "top")
    first = client.camera.position
    grow(41)  # 5 cm more on a 2 m map: within the margin
    assert not node._follow_growth(client) and client.camera.position == first
    grow(80)
    assert node._follow_growth(client), "the map outgrew the view: framed again"
    assert client.camera.position[2] > first[2], "from higher up"
    second = client.camera.position
    client.camera.position, client.camera.look_at = first, node.framing.top_views[7][1][-2].look_at  # reported late
    grow(160)
    assert node._follow_growth(client), "a camera the view was given earlier is not the user's"
    assert client.camera.position[2] > second[2]
    client.camera.position = (0.5, 0.5, 3.0)  # the user turned the view
    grow(240)
    assert not node._follow_growth(client) and client.camera.position == (0.5, 0.5, 3.0), "the user's camera kept"
    node._frame(client, "top")  # Top view pressed: followed again
    grow(480)
    assert node._follow_growth(client)
