"""The slam node builds /map on a thread of its own (MapWorker): the /pose answering a pair never waits for a map
build, the thread stops with the node (nothing published after deactivate), and the map it publishes is the
library's at the same poses, cell for cell."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest
from conftest import spin_until
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import LaserScan

from amr_interfaces.msg import LocalizedPose, PoseGraph
from amr_interfaces.srv import SaveMap
from amr_mapping.slam import GraphSlam, KeptMap, SlamConfig
from amr_mapping.slam_node import MapWorker, SlamNode
from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import world_from_dict
from amr_util.messages import quaternion
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_util.scan import ScanData
from amr_util.stamps import stamp_from_nanoseconds, stamp_nanoseconds

BEAMS = 180
INCREMENT = 2.0 * math.pi / BEAMS
MAX_RANGE = 6.0
STEP_NS = 100_000_000
SLOW_BUILD = 1.0
"""s a slowed map build sleeps."""


@pytest.fixture(scope="module")
def room():
    """A 6 x 4 m room with two boxes, and a path of 0.3 m steps along it (a node at every scan)."""
    world = world_from_dict(
        {
            "walls": [[0, 0, 6, 0], [6, 0, 6, 4], [6, 4, 0, 4], [0, 4, 0, 0]],
            "wall_thickness": 0.1,
            "start": [1, 1, 0],
            "boxes": [[2.5, 1.8, 3.0, 2.4], [4.5, 0.0, 4.8, 0.5]],
        }
    )
    caster = NumpyRayCaster(world.faces)
    path = [(1.0 + 0.3 * k, 1.0 + 0.05 * k, 0.02 * k) for k in range(12)]
    scans = [caster.cast(x, y, theta - math.pi, INCREMENT, BEAMS, MAX_RANGE) for x, y, theta in path]
    return path, scans


class Probe:
    """Publishes /odometry + /scan pairs and records what the slam node sends back, with the time it came."""

    def __init__(self, context) -> None:
        self.node = Node("map_thread_probe", context=context)
        self.odometry = self.node.create_publisher(Odometry, "odometry", reliable(10))
        self.scan = self.node.create_publisher(LaserScan, "scan", SENSOR_DATA)
        self.poses: list[tuple[int, float]] = []
        self.maps: list[tuple[OccupancyGridMessage, float]] = []
        self.graphs: list[PoseGraph] = []
        self.node.create_subscription(LocalizedPose, "pose", self._on_pose, 10)
        self.node.create_subscription(
            OccupancyGridMessage, "map", lambda m: self.maps.append((m, time.monotonic())), LATCHED
        )
        self.node.create_subscription(PoseGraph, "slam/graph", self.graphs.append, LATCHED)

    def _on_pose(self, message: LocalizedPose) -> None:
        self.poses.append((stamp_nanoseconds(message.header.stamp), time.monotonic()))

    def connected(self) -> bool:
        return (
            self.odometry.get_subscription_count() > 0
            and self.scan.get_subscription_count() > 0
            and self.node.count_publishers("/pose") > 0
            and self.node.count_publishers("/map") > 0
        )

    def send(self, k: int, pose, ranges) -> int:
        """Pair k: the odometry (the true pose: no drift) and the scan, both stamped k steps in."""
        stamp_ns = (k + 1) * STEP_NS
        stamp = stamp_from_nanoseconds(stamp_ns)
        odometry = Odometry()
        odometry.header.stamp, odometry.header.frame_id, odometry.child_frame_id = stamp, "odom", "base_footprint"
        odometry.pose.pose.position.x, odometry.pose.pose.position.y = float(pose[0]), float(pose[1])
        odometry.pose.pose.orientation = quaternion(float(pose[2]))
        scan = LaserScan(angle_min=-math.pi, angle_increment=INCREMENT, range_min=0.1, range_max=MAX_RANGE)
        scan.header.stamp, scan.header.frame_id = stamp, "base_scan"
        scan.angle_max = -math.pi + INCREMENT * (BEAMS - 1)
        scan.ranges = [float(r) for r in ranges]
        self.odometry.publish(odometry)
        self.scan.publish(scan)
        return stamp_ns

    def answered(self, stamp_ns: int) -> float | None:
        return next((at for stamp, at in self.poses if stamp == stamp_ns), None)


@pytest.fixture
def stack(executor):
    """An active slam node (a /map at every change: map_publish_period 0) and a connected probe."""
    slam = SlamNode(
        context=executor.context,
        parameter_overrides=[
            Parameter("lidar_x", value=0.0),
            Parameter("max_range_used", value=MAX_RANGE),
            Parameter("map_publish_period", value=0.0),
        ],
    )
    probe = Probe(executor.context)
    executor.add_node(slam)
    executor.add_node(probe.node)
    assert slam.try_transition(Transition.TRANSITION_CONFIGURE), slam.configure_error
    assert slam.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, probe.connected, 10.0), "the probe and the slam node did not meet"
    try:
        yield slam, probe
    finally:
        slam.shut_down_cleanly()
        executor.remove_node(probe.node)
        executor.remove_node(slam)
        probe.node.destroy_node()
        slam.destroy_node()


@pytest.fixture
def slow_build(monkeypatch):
    """KeptMap.build sleeping SLOW_BUILD s first; `started` is set when a build begins."""
    started = threading.Event()
    build = KeptMap.build

    def slow(self, snapshot, pause=None):
        started.set()
        time.sleep(SLOW_BUILD)
        return build(self, snapshot, pause)

    monkeypatch.setattr(KeptMap, "build", slow)
    return started


def test_the_pose_answering_a_pair_does_not_wait_for_the_map(executor, stack, room, slow_build):
    slam, probe = stack
    path, scans = room
    first = probe.send(0, path[0], scans[0])
    assert spin_until(executor, lambda: probe.answered(first) is not None, 5.0), "no /pose for the first pair"
    assert slow_build.wait(5.0), "the first node's map was not asked for"
    # the next pair comes while that map is being built: its /pose is not held by the build
    sent = time.monotonic()
    second = probe.send(1, path[1], scans[1])
    assert spin_until(executor, lambda: probe.answered(second) is not None, 5.0), "no /pose for the second pair"
    assert probe.answered(second) - sent < 0.5 * SLOW_BUILD, probe.answered(second) - sent
    assert not probe.maps, "the map came before the /pose of the pair sent during its build"
    # and the maps come afterwards: the first, then one more for the change asked for during its build
    assert spin_until(
        executor,
        lambda: len(probe.maps) >= 2 and probe.graphs and len(probe.graphs[-1].poses) == 2,
        4 * SLOW_BUILD + 5.0,
    ), f"{len(probe.maps)} maps, {len(probe.graphs)} graphs"
    assert probe.maps[0][1] > probe.answered(second)
    assert stamp_nanoseconds(probe.maps[-1][0].header.stamp) == second and slam.maps_published == 2


def test_the_map_thread_stops_on_deactivate_and_cleanup_and_nothing_is_published_after(
    executor, stack, room, slow_build
):
    slam, probe = stack
    path, scans = room
    worker = slam._map_worker
    assert worker is not None and worker.alive
    probe.send(0, path[0], scans[0])
    assert spin_until(executor, slow_build.is_set, 5.0), "no map build started"
    assert slam.try_transition(Transition.TRANSITION_DEACTIVATE)  # joins the thread: its build ends unpublished
    assert not worker.alive and slam._map_worker is None
    published = slam.maps_published
    assert not spin_until(executor, lambda: probe.maps or slam.maps_published > published, SLOW_BUILD)
    # active again: a new thread, and the map left unpublished goes out without a new scan (the flush timer)
    slow_build.clear()
    assert slam.try_transition(Transition.TRANSITION_ACTIVATE)
    worker = slam._map_worker
    assert worker is not None and worker.alive
    assert spin_until(executor, lambda: probe.maps, 3 * SLOW_BUILD + 5.0), "the map left unpublished never came"
    assert slam.try_transition(Transition.TRANSITION_DEACTIVATE)
    assert slam.try_transition(Transition.TRANSITION_CLEANUP)
    assert not worker.alive and slam._map_worker is None


def test_the_map_published_is_the_librarys_at_the_same_poses_cell_for_cell(executor, stack, room):
    slam, probe = stack
    path, scans = room
    for k, (pose, ranges) in enumerate(zip(path, scans, strict=True)):
        stamp_ns = probe.send(k, pose, ranges)
        assert spin_until(executor, lambda s=stamp_ns: probe.answered(s) is not None, 5.0), f"no /pose for pair {k}"
    last = stamp_ns
    assert spin_until(
        executor, lambda: probe.maps and stamp_nanoseconds(probe.maps[-1][0].header.stamp) == last, 10.0
    ), "no map of the last pair"
    assert spin_until(executor, lambda: probe.graphs and len(probe.graphs[-1].poses) == len(path), 5.0)
    message = probe.maps[-1][0]
    library = slam.slam.occupancy_grid()  # the library's own kept map, at the graph's poses now
    poses = slam.slam.graph()[0]
    assert len(poses) == len(path) > 5
    assert np.allclose([(p.x, p.y, p.theta) for p in probe.graphs[-1].poses], poses, atol=1e-12)
    assert (message.info.height, message.info.width) == library.data.shape
    assert message.info.resolution == pytest.approx(library.resolution)
    assert (message.info.origin.position.x, message.info.origin.position.y) == pytest.approx(library.origin[:2])
    data = np.asarray(message.data, dtype=np.int8).reshape(library.data.shape)
    np.testing.assert_array_equal(data, library.data)
    assert (data == 100).sum() > 50 and (data == 0).sum() > 500


def test_a_build_with_pauses_is_the_build_without_them_and_pauses_between_chunks(room, monkeypatch):
    path, scans = room
    slam = GraphSlam(SlamConfig(lidar_x=0.0, max_range_used=MAX_RANGE))
    for k, (pose, ranges) in enumerate(zip(path, scans, strict=True)):
        slam.add((k + 1) * STEP_NS, pose, ScanData(ranges, -math.pi, INCREMENT, 0.1, MAX_RANGE))
    snapshot = slam.snapshot()
    assert len(snapshot.nodes) == len(snapshot.poses) == len(snapshot.node_stamps) == len(path)
    monkeypatch.setattr(KeptMap, "CHUNK", 5)
    pauses = []
    paused = KeptMap(slam.config.resolution).build(snapshot, pause=lambda: pauses.append(1))
    assert len(pauses) == 3  # between the chunks of 5, 5 and 2 scans, and before the conversion
    whole = KeptMap(slam.config.resolution).build(snapshot)
    assert paused.origin == whole.origin
    np.testing.assert_array_equal(paused.data, whole.data)
    np.testing.assert_array_equal(whole.data, slam.occupancy_grid().data)


def test_map_worker_coalesces_requests_made_during_a_job_and_outlives_a_failed_one():
    done: list[int] = []
    errors: list[BaseException] = []
    running, release = threading.Event(), threading.Event()

    def job(value: int) -> None:
        running.set()
        release.wait(5.0)
        if value == 3:
            raise RuntimeError("a failed build")
        done.append(value)

    worker = MapWorker(job, errors.append, "test map")
    worker.start()
    try:
        worker.request(1)
        assert running.wait(5.0)
        for value in (2, 3):  # while job 1 runs: one more job after it, for the newest request
            worker.request(value)
        release.set()
        deadline = time.monotonic() + 5.0
        while not errors and time.monotonic() < deadline:
            time.sleep(0.01)
        assert done == [1] and [str(e) for e in errors] == ["a failed build"]
        worker.request(4)  # the thread outlived the failure
        while done != [1, 4] and time.monotonic() < deadline:
            time.sleep(0.01)
        assert done == [1, 4]
    finally:
        release.set()
        worker.stop()
    assert not worker.alive


def test_a_save_that_moves_the_poses_publishes_the_map_at_them(executor, stack, room, tmp_path, monkeypatch):
    """~/save_map finishes a pending optimization (the map saved is the optimized graph's): /map follows the poses it
    saved without a new scan (a robot standing still once exploration is done), as the file does."""
    slam, probe = stack
    path, scans = room
    for k in range(4):
        stamp_ns = probe.send(k, path[k], scans[k])
        assert spin_until(executor, lambda s=stamp_ns: probe.answered(s) is not None, 5.0), f"no /pose for pair {k}"
    assert spin_until(executor, lambda: probe.graphs and len(probe.graphs[-1].poses) == 4, 10.0), "no graph of 4"
    published = slam.maps_published
    graph = slam.slam._graph

    def optimizing_settle():  # as an optimization left pending would: the poses after the first node move
        moved = graph.poses
        moved[1:, :2] += (0.2, -0.1)
        graph.set_poses(moved)
        return True

    monkeypatch.setattr(slam.slam, "settle", optimizing_settle)
    answer = slam._on_save_map(SaveMap.Request(path=str(tmp_path / "room")), SaveMap.Response())
    assert answer.success, answer.message
    assert spin_until(executor, lambda: slam.maps_published > published, 10.0), "no /map after the save"
    assert spin_until(executor, lambda: abs(probe.graphs[-1].poses[1].x - graph.poses[1][0]) < 1e-6, 5.0), (
        "the graph published is not at the poses saved"
    )
    saved = np.loadtxt(tmp_path / "room.poses.csv", delimiter=",", ndmin=2, skiprows=1)
    assert np.allclose(saved[:, 1:3], graph.poses[:, :2], atol=1e-6)
