"""What a SLAM graph and a growing map cost the viewer: decoding and drawing them, by size.

    python bench/bench_viewer_slam.py [--sizes 1000 5000] [--cells 200 800] [--repeats 20]

For each size: a graph of N nodes along a Manhattan walk with N - 1 sequential edges and N / 5 loop closures,
serialized by rclpy as the slam node publishes it; then, median ms of --repeats:

  cdr      amr_viewer.cdr.pose_graph + amr_viewer.state.pose_graph_view (the viewer's path);
  rclpy    rclpy's deserialize_message + the same arrays built from its Python objects (the path not taken);
  draw     amr_viewer.scene.Scene drawing the new graph into a viser server (no browser connected);
  bytes    the message's size.

Then for each map of --cells x --cells cells (half unknown, walls and free space): rclpy's deserialize_message and
the gray image (the viewer's path for /map), and the scene's redraw of it (an image upscaled to about 1,024 px,
PNG-encoded for the browser). The slam node sends its graph with each /map (at most every map_publish_period, 1 s
by default), so these run at most once a second. On a machine shared with other work the times move with its load.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import statistics
import time

import numpy as np
import viser
from geometry_msgs.msg import Pose2D
from nav_msgs.msg import OccupancyGrid
from rclpy.serialization import deserialize_message, serialize_message

from amr_interfaces.msg import PoseGraph
from amr_viewer import cdr, messages
from amr_viewer.scene import Scene
from amr_viewer.state import RobotState, pose_graph_view


def graph_bytes(count: int, seed: int = 0) -> bytes:
    rng = np.random.default_rng(seed)
    steps = rng.choice([[0.2, 0.0], [0.0, 0.2], [-0.2, 0.0], [0.0, -0.2]], count)
    xy = np.cumsum(steps, axis=0)
    message = PoseGraph()
    message.header.frame_id = "map"
    message.poses = [Pose2D(x=float(x), y=float(y), theta=0.0) for x, y in xy]
    closures = rng.integers(0, count, (count // 5, 2))
    message.edge_from = list(range(count - 1)) + closures[:, 0].tolist()
    message.edge_to = list(range(1, count)) + closures[:, 1].tolist()
    message.loop_closure = [False] * (count - 1) + [True] * len(closures)
    return serialize_message(message)


def map_bytes(cells: int, seed: int = 0) -> bytes:
    rng = np.random.default_rng(seed)
    data = np.full((cells, cells), -1, dtype=np.int8)
    data[: cells // 2] = rng.choice(np.array([0, 0, 0, 100], dtype=np.int8), (cells // 2, cells))
    message = OccupancyGrid()
    message.header.frame_id = "map"
    message.info.width = message.info.height = cells
    message.info.resolution = 0.05
    message.info.origin.orientation.w = 1.0
    message.data = data.ravel().tolist()
    return serialize_message(message)


def via_cdr(data: bytes):
    graph = cdr.pose_graph(data)
    return pose_graph_view(graph.poses, graph.edge_from, graph.edge_to, graph.loop_closure)


def via_rclpy(data: bytes):
    message = deserialize_message(data, PoseGraph)
    poses = np.array([(p.x, p.y, p.theta) for p in message.poses], dtype=float).reshape(-1, 3)
    return pose_graph_view(poses, message.edge_from, message.edge_to, message.loop_closure)


def median_ms(work, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        work()
        times.append(1000.0 * (time.perf_counter() - start))
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 5000])
    parser.add_argument("--cells", type=int, nargs="+", default=[200, 800])
    parser.add_argument("--repeats", type=int, default=20)
    options = parser.parse_args()
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        scene = Scene(server)
        print(f"{'nodes':>6} {'edges':>6} {'bytes':>8} {'cdr ms':>8} {'rclpy ms':>9} {'draw ms':>8}")
        for size in options.sizes:
            data = graph_bytes(size)
            fast, slow = via_cdr(data), via_rclpy(data)
            assert np.array_equal(fast.poses, slow.poses) and np.array_equal(fast.edges, slow.edges)
            state = RobotState("")

            def draw(state=state, view=fast) -> None:
                state.on_graph(view, "map")
                scene.draw(state)

            fast_ms = median_ms(lambda data=data: via_cdr(data), options.repeats)
            slow_ms = median_ms(lambda data=data: via_rclpy(data), options.repeats)
            draw_ms = median_ms(draw, options.repeats)
            print(f"{size:>6} {len(fast.edges):>6} {len(data):>8} {fast_ms:>8.2f} {slow_ms:>9.2f} {draw_ms:>8.2f}")
        print(f"\n{'cells':>9} {'bytes':>8} {'decode ms':>10} {'draw ms':>8}")
        for cells in options.cells:
            data = map_bytes(cells)
            state = RobotState("")

            def decode(data=data):
                grid = deserialize_message(data, OccupancyGrid)
                return messages.occupancy_grid(grid)

            image = decode()

            def draw_map(state=state, image=image) -> None:
                state.on_map(image, "map")
                scene.draw(state)

            decode_ms, draw_ms = median_ms(decode, options.repeats), median_ms(draw_map, options.repeats)
            print(f"{cells:>4}x{cells:<4} {len(data):>8} {decode_ms:>10.2f} {draw_ms:>8.2f}")
    finally:
        server.stop()


if __name__ == "__main__":
    main()
