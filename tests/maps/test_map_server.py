"""map_server: OccupancyGrid <-> nav_msgs both ways, the map's source, and the node (/map latched, ~/map)."""

import numpy as np
import pytest
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from nav_msgs.srv import GetMap
from rclpy.node import Node
from rclpy.parameter import Parameter
from support.ros import spin_until

from amr_maps.map_io import save_map
from amr_maps.map_server_node import MapServerNode
from amr_maps.map_source import load_grid
from amr_maps.messages import grid_from_message, grid_message
from amr_maps.occupancy_grid import MapError, OccupancyGrid
from amr_maps.rasterize import rasterize_world
from amr_maps.world import load_world, resolve_world_path
from amr_util.qos import LATCHED
from amr_util.stamps import stamp_from_seconds as stamp

RNG = np.random.default_rng(5)
TIMEOUT = 10.0


@pytest.mark.parametrize("shape", [(1, 1), (3, 7), (40, 25), (120, 1)])
def test_a_grid_survives_the_message_both_ways(shape):
    data = RNG.choice(np.array([-1, 0, 37, 100], dtype=np.int8), size=shape)
    grid = OccupancyGrid(
        data, float(RNG.uniform(0.01, 0.5)), (float(RNG.uniform(-9, 9)), float(RNG.uniform(-9, 9)), 0.0), "odom"
    )
    message = grid_message(grid, stamp(3.5))
    height, width = shape
    assert (message.info.width, message.info.height, message.header.frame_id) == (width, height, "odom")
    assert message.info.map_load_time == message.header.stamp
    assert list(message.data[:width]) == list(data[0])  # row-major from cell (0, 0), the bottom row
    assert (message.info.origin.position.x, message.info.origin.position.y) == grid.origin[:2]
    back = grid_from_message(message)
    assert np.array_equal(back.data, grid.data) and back.resolution == pytest.approx(grid.resolution)
    assert back.origin == grid.origin and back.frame_id == "odom"


def test_an_inconsistent_message_is_refused_by_field():
    message = grid_message(OccupancyGrid(np.zeros((2, 3), dtype=np.int8), 0.1), stamp(0.0))
    message.info.width = 4
    with pytest.raises(MapError, match="data has 6 cells, info says 4 x 2"):
        grid_from_message(message)


def test_the_map_comes_from_exactly_one_of_yaml_filename_and_world(tmp_path):
    for values in ({}, {"yaml_filename": "a.yaml", "world": "inner_maze.yaml"}):
        with pytest.raises(MapError, match="yaml_filename, world: give exactly one"):
            load_grid(values)
    grid = load_grid({"world": "hard_maze.yaml", "resolution": 0.02})
    expected = rasterize_world(load_world(resolve_world_path("hard_maze.yaml")), 0.02)
    assert np.array_equal(grid.data, expected.data) and grid.origin == expected.origin
    saved = save_map(expected, tmp_path / "hard")
    assert np.array_equal(load_grid({"yaml_filename": str(saved)}).data, expected.data)


@pytest.mark.parametrize(
    "text, key",
    [
        ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\nfree_thresh: 0.2\n", "occupied_thresh"),
        (
            "image: gone.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\n"
            "free_thresh: 0.2\n",
            "image",
        ),
        (
            "image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
            "resolution",
        ),
    ],
)
def test_a_malformed_map_file_is_refused_naming_file_and_key(tmp_path, text, key):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    (tmp_path / "m.pgm").write_bytes(b"")
    with pytest.raises(MapError) as error:
        load_grid({"yaml_filename": str(path)})
    assert str(path) in str(error.value) and f"{key}:" in str(error.value)


class LateJoiner(Node):
    def __init__(self, context):
        super().__init__("map_late_joiner", context=context)
        self.maps: list[OccupancyGridMessage] = []
        self.create_subscription(OccupancyGridMessage, "/map", self.maps.append, LATCHED)
        self.get_map = self.create_client(GetMap, "/map_server/map")


def map_server(context, **params) -> MapServerNode:
    return MapServerNode(context=context, parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])


def test_the_node_latches_the_map_for_a_late_subscriber_and_answers_get_map(ros_context, executor):
    server = map_server(ros_context, world="inner_maze.yaml", resolution=0.05)
    executor.add_node(server)
    assert server.try_transition(Transition.TRANSITION_CONFIGURE) and server.try_transition(
        Transition.TRANSITION_ACTIVATE
    )
    late = LateJoiner(ros_context)  # joins after the map went out
    executor.add_node(late)
    assert spin_until(executor, lambda: late.maps, TIMEOUT), "a late subscriber did not get the latched /map"
    expected = rasterize_world(load_world(resolve_world_path("inner_maze.yaml")), 0.05)
    got = grid_from_message(late.maps[0])
    assert late.maps[0].header.frame_id == "map" and got.resolution == pytest.approx(0.05)
    assert got.origin == pytest.approx(expected.origin) and np.array_equal(got.data, expected.data)
    assert late.get_map.wait_for_service(timeout_sec=TIMEOUT)
    future = late.get_map.call_async(GetMap.Request())
    executor.spin_until_future_complete(future, timeout_sec=TIMEOUT)
    assert future.done() and np.array_equal(grid_from_message(future.result().map).data, expected.data)


def test_a_bad_map_fails_configure_and_leaves_nothing_behind(ros_context, executor, tmp_path, capfd):
    path = tmp_path / "lab.yaml"
    path.write_text(
        "image: lab.pgm\nresolution: 0.05\norigin: [0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n"
    )
    server = map_server(ros_context, yaml_filename=str(path))
    executor.add_node(server)
    assert not server.try_transition(Transition.TRANSITION_CONFIGURE)
    assert server.state_label == "unconfigured"
    assert all(publisher.topic_name != "/map" for publisher in server.publishers)
    assert f"{path}: origin: expected [x, y, yaw]" in capfd.readouterr().err
    bad_world = map_server(ros_context, world="no_such_world.yaml")
    executor.add_node(bad_world)
    assert not bad_world.try_transition(Transition.TRANSITION_CONFIGURE)
    assert "world: world file 'no_such_world.yaml' not found" in capfd.readouterr().err
