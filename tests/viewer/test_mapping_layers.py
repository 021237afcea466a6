"""SLAM in the viewer without ROS: the pose graph and the frontiers read from CDR, checked (a wrong frame, a NaN, an
edge to no node: skipped, the state kept), said in the status panel and drawn in a real viser server."""

import contextlib
import io
import math

import numpy as np
import pytest
import viser
from geometry_msgs.msg import Point
from geometry_msgs.msg import Pose2D as Pose2DMessage
from rclpy.serialization import serialize_message

from amr_interfaces.msg import Frontiers, PoseGraph
from amr_util.geometry import Pose2D
from amr_viewer import cdr, status
from amr_viewer.geometry import outgrown
from amr_viewer.scene import COLORS, TOGGLED, Scene
from amr_viewer.state import RobotState, Skipped, frontier_view, map_image, pose_graph_view
from amr_viewer.topics import FRONTIERS, POSE_GRAPH, node_topic

RNG = np.random.default_rng(37)


def graph_message(poses, edges, loop, frame="map") -> PoseGraph:
    message = PoseGraph()
    message.header.frame_id = frame
    message.header.stamp.sec, message.header.stamp.nanosec = 12, 500_000_000
    message.poses = [Pose2DMessage(x=float(x), y=float(y), theta=float(t)) for x, y, t in poses]
    message.edge_from = [int(a) for a, _ in edges]
    message.edge_to = [int(b) for _, b in edges]
    message.loop_closure = [bool(flag) for flag in loop]
    return message


def frontiers_message(centroids, sizes, chosen=-1, state="exploring", frame="map") -> Frontiers:
    message = Frontiers(chosen=chosen, blacklisted=2, state=state)
    message.header.frame_id = frame
    message.centroids = [Point(x=float(x), y=float(y), z=0.0) for x, y in centroids]
    message.sizes = [int(size) for size in sizes]
    return message


def chain(count: int, closures: int = 0):
    """A graph of `count` nodes in a row, with `closures` loop closures back to node 0."""
    poses = np.column_stack([np.arange(count) * 0.2, RNG.uniform(-0.1, 0.1, count), RNG.uniform(-3, 3, count)])
    edges = [(k, k + 1) for k in range(count - 1)] + [(count - 1 - k, 0) for k in range(closures)]
    return poses, edges, [False] * (count - 1) + [True] * closures


@pytest.mark.parametrize("count,closures,frame", [(0, 0, "map"), (1, 0, "m"), (2, 0, "map"), (700, 9, "robot_1/map")])
def test_the_pose_graph_is_read_from_cdr_as_rclpy_wrote_it(count, closures, frame):
    poses, edges, loop = chain(count, closures if count > closures else 0)
    parsed = cdr.pose_graph(serialize_message(graph_message(poses, edges, loop, frame)))
    assert parsed.header.frame_id == frame and parsed.header.stamp == pytest.approx(12.5)
    assert parsed.poses.shape == (count, 3) and parsed.poses == pytest.approx(poses.reshape(-1, 3))
    assert parsed.edge_from.tolist() == [a for a, _ in edges] and parsed.edge_to.tolist() == [b for _, b in edges]
    assert parsed.loop_closure.tolist() == loop


@pytest.mark.parametrize("count,chosen,state", [(0, -1, "done"), (1, 0, "exploring"), (6, 3, "x" * 13)])
def test_the_frontiers_are_read_from_cdr_as_rclpy_wrote_them(count, chosen, state):
    centroids, sizes = RNG.uniform(-4, 4, (count, 2)), RNG.integers(1, 400, count)
    parsed = cdr.frontiers(serialize_message(frontiers_message(centroids, sizes, chosen, state)))
    assert parsed.header.frame_id == "map" and parsed.centroids == pytest.approx(centroids.reshape(-1, 2))
    assert parsed.sizes.tolist() == sizes.tolist()
    assert (parsed.chosen, parsed.blacklisted, parsed.state) == (chosen, 2, state)
    with pytest.raises(cdr.CdrError, match="ends early"):
        cdr.frontiers(serialize_message(frontiers_message(centroids, sizes, chosen, state))[:-8])


def test_each_new_graph_and_frontiers_replace_the_drawn_ones():
    state = RobotState("")
    poses, edges, loop = chain(5)
    state.on_graph(pose_graph_view(poses, *zip(*edges, strict=True), loop), "map")
    assert state.versions["graph"] == 1 and state.graph.loop_closures == 0 and len(state.graph.poses) == 5
    poses, edges, loop = chain(8, 2)
    state.on_graph(pose_graph_view(poses, *zip(*edges, strict=True), loop), "/map")
    graph = state.graph
    assert state.versions["graph"] == 2 and len(graph.poses) == 8 and graph.loop_closures == 2
    assert graph.segments(True) == pytest.approx(np.array([poses[[7, 0], :2], poses[[6, 0], :2]]))
    assert graph.segments(False).shape == (7, 2, 2)
    state.on_frontiers(frontier_view([[1.0, 2.0], [3.0, -1.0]], [12, 30], 1, 0, "exploring"), "")
    assert state.frontiers.chosen_centroid == pytest.approx((3.0, -1.0)), "an empty frame is the map frame"
    state.on_frontiers(frontier_view(np.zeros((0, 2)), [], -1, 4, "done"), "map")
    assert state.versions["frontiers"] == 2 and state.frontiers.chosen_centroid is None
    assert state.frontiers.state == "done"
    assert state.versions["map"] == 0 and state.versions["robot"] == 0, "nothing else redrawn"


def test_a_wrong_frame_or_a_nan_is_skipped_and_the_state_kept():
    state = RobotState("")
    poses, edges, loop = chain(4, 1)
    good = pose_graph_view(poses, *zip(*edges, strict=True), loop)
    state.on_graph(good, "map")
    with pytest.raises(Skipped, match="frame 'odom', not 'map'") as refused:
        state.on_graph(good, "odom")
    assert refused.value.kind == "frame" and state.versions["graph"] == 1
    poses[2, 1] = math.nan
    with pytest.raises(Skipped, match="node 2 of 4") as refused:
        pose_graph_view(poses, *zip(*edges, strict=True), loop)
    assert refused.value.kind == "nan"
    with pytest.raises(Skipped, match="edge 1 joins nodes \\(1, 9\\)") as refused:
        pose_graph_view(np.zeros((4, 3)), [0, 1], [1, 9], [False, True])
    assert refused.value.kind == "malformed"
    with pytest.raises(Skipped, match="2 edge_from, 1 edge_to"):
        pose_graph_view(np.zeros((4, 3)), [0, 1], [1], [False, True])
    with pytest.raises(Skipped, match="frontier 1 of 2") as refused:
        frontier_view([[0.0, 0.0], [math.inf, 1.0]], [3, 4], 0, 0, "exploring")
    assert refused.value.kind == "nan"
    with pytest.raises(Skipped, match="chosen frontier 2 of 2"):
        frontier_view([[0.0, 0.0], [1.0, 1.0]], [3, 4], 2, 0, "exploring")
    with pytest.raises(Skipped, match="frame 'base_footprint'"):
        state.on_frontiers(frontier_view([[0.0, 0.0]], [3], 0, 0, "exploring"), "base_footprint")
    assert state.frontiers is None and state.graph is good
    image = map_image(2, 2, 0.1, Pose2D(0.0, 0.0, 0.0), [0, 0, 0, 100])
    with pytest.raises(Skipped, match="map in frame 'odom'"):
        state.on_map(image, "odom")
    assert state.map is None
    with pytest.raises(Skipped, match="not finite") as refused:
        map_image(2, 2, 0.1, Pose2D(math.nan, 0.0, 0.0), [0, 0, 0, 100])
    assert refused.value.kind == "nan"


def test_a_fleet_robot_takes_the_roots_map_frame_or_its_own_prefixed_one():
    state = RobotState("/r1")
    view = frontier_view([[0.0, 0.0]], [3], 0, 0, "exploring")
    state.on_frontiers(view, "map")
    state.on_frontiers(view, "r1/map")
    with pytest.raises(Skipped):
        state.on_frontiers(view, "r2/map")
    assert state.versions["frontiers"] == 2


def test_the_status_panel_says_the_graph_the_explorer_and_what_was_not_drawn():
    poses, edges, loop = chain(6, 2)
    graph = pose_graph_view(poses, *zip(*edges, strict=True), loop)
    frontiers = frontier_view([[0.0, 0.0], [1.0, 0.0]], [3, 8], 1, 2, "exploring")
    assert status.mapping_texts(graph, frontiers, {"graph": 1, "map": 0}) == [
        "graph 6 nodes, 7 edges, 2 loop closures",
        "explorer exploring: 2 frontiers, one chosen, 2 given up",
        "1 graph message not drawn (see the log)",
    ]
    assert status.mapping_texts(None, None, {}) == []


def test_a_slam_node_or_explorer_by_another_name_is_found_by_type():
    graph = {
        "/slam_toolbox/graph": {"visualization_msgs/msg/MarkerArray"},
        "/mapper/graph": {POSE_GRAPH},
        "/r1/mapper/graph": {POSE_GRAPH},
        "/r1/explore/frontiers": {FRONTIERS},
    }
    assert node_topic(graph, "", "graph", POSE_GRAPH) == "/mapper/graph"
    assert node_topic(graph, "/r1", "graph", POSE_GRAPH) == "/r1/mapper/graph"
    assert node_topic(graph, "/r1", "frontiers", FRONTIERS) == "/r1/explore/frontiers"
    assert node_topic(graph, "", "frontiers", FRONTIERS) is None


@pytest.fixture
def server():
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield server
    server.stop()


def test_the_graph_and_frontiers_are_drawn_in_their_colours_and_can_be_hidden(server):
    scene, state = Scene(server), RobotState("")
    poses, edges, loop = chain(10, 3)
    state.on_graph(pose_graph_view(poses, *zip(*edges, strict=True), loop))
    state.on_frontiers(frontier_view([[1.0, 1.0], [2.0, -1.0]], [10, 20], 0, 0, "exploring"))
    scene.draw(state)
    handles = scene._handles
    loops, edges_drawn = handles["/robots/root/graph/loops"], handles["/robots/root/graph/edges"]
    assert loops.points.shape == (3, 2, 3) and edges_drawn.points.shape == (9, 2, 3)
    assert np.all(loops.colors == np.array(COLORS["loop_closures"], dtype=np.uint8))
    assert np.all(edges_drawn.colors == np.array(COLORS["graph_edges"], dtype=np.uint8))
    assert handles["/robots/root/graph/nodes"].points.shape == (10, 3)
    assert handles["/robots/root/frontiers/centroids"].points.shape == (2, 3)
    ring = handles["/robots/root/frontiers/chosen"].points
    assert np.hypot(ring[:, :, 0] - 1.0, ring[:, :, 1] - 1.0).max() == pytest.approx(0.12), "around the chosen one"
    assert {"map", "graph", "frontiers"} <= set(TOGGLED)
    scene.set_hidden("graph", True)
    assert not loops.visible and not handles["/robots/root/graph/nodes"].visible
    assert handles["/robots/root/frontiers/centroids"].visible
    state.on_frontiers(frontier_view(np.zeros((0, 2)), [], -1, 0, "done"))
    scene.draw(state)
    assert "/robots/root/frontiers/chosen" not in handles and "/robots/root/frontiers/centroids" not in handles
    poses, edges, loop = chain(12)
    state.on_graph(pose_graph_view(poses, *zip(*edges, strict=True), loop))
    scene.draw(state)
    assert "/robots/root/graph/loops" not in handles, "no loop closure left: none drawn"
    assert handles["/robots/root/graph/edges"].points.shape == (11, 2, 3)
    assert not handles["/robots/root/graph/edges"].visible, "still hidden"


def test_a_map_has_outgrown_its_view_beyond_a_margin_on_any_side():
    framed = (-1.0, -1.0, 1.0, 1.0)
    assert not outgrown(framed, framed) and not outgrown(framed, (-1.09, -0.5, 1.09, 0.5)), "within 5 % of 2 m"
    for side in range(4):
        grown = list(framed)
        grown[side] += 0.15 if side >= 2 else -0.15
        assert outgrown(framed, tuple(grown)), f"side {side}"
