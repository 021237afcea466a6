"""Just enough of a CDR reader for the busy topics, so the viewer takes them raw and decodes only what it draws.

A viewer subscribed to /tf and /ground_truth sees every step of a lockstep run, and a /particle_cloud of 5,000
particles is 280 kB; rclpy's deserialization makes a Python object per pose. These readers pull the few fields the
view needs straight from the serialized bytes (XCDR1, as rmw_fastrtps writes it: a 4-byte encapsulation header,
then fields aligned to their size from the end of that header); the particles come out as one numpy array, and so do
a SLAM pose graph's nodes and edges and the explorer's frontiers. Bytes in another encapsulation (XCDR2, as another
middleware may send: `fast_path_applies` is False) are deserialized by rclpy and converted to the same plain data
(amr_viewer.messages; viewer_node decides).
"""

from __future__ import annotations

import struct
from typing import NamedTuple

import numpy as np

from amr_util.geometry import Pose2D, yaw_from_quaternion


class Quaternion(NamedTuple):
    x: float
    y: float
    z: float
    w: float


class CdrError(ValueError):
    """Bytes that are not the message they were taken for."""


class Stamped(NamedTuple):
    frame_id: str
    stamp: float
    """s (sec + nanosec)"""


class StampedTransform(NamedTuple):
    parent: str
    child: str
    stamp: float
    pose: Pose2D


def fast_path_applies(data: bytes) -> bool:
    """The bytes are plain CDR (XCDR1, big- or little-endian), what these readers read."""
    return len(data) >= 4 and data[0] == 0 and data[1] in (0, 1)


class Reader:
    """Reads CDR fields in order from a serialized message."""

    def __init__(self, data: bytes) -> None:
        if not fast_path_applies(data):
            raise CdrError("not a CDR message (bad encapsulation header)")
        self._data = memoryview(data)[4:]
        self._order = "<" if data[1] == 1 else ">"
        self._position = 0

    def _take(self, size: int, count: int = 1) -> int:
        self._position += -self._position % size
        start = self._position
        self._position += size * count
        if self._position > len(self._data):
            raise CdrError("message ends early")
        return start

    def uint32(self) -> int:
        return struct.unpack_from(self._order + "I", self._data, self._take(4))[0]

    def int32(self) -> int:
        return struct.unpack_from(self._order + "i", self._data, self._take(4))[0]

    def float64s(self, count: int) -> tuple[float, ...]:
        return struct.unpack_from(f"{self._order}{count}d", self._data, self._take(8, count))

    def float64_array(self, count: int) -> np.ndarray:
        start = self._take(8, count) if count else self._position
        return np.frombuffer(self._data, dtype=np.dtype(self._order + "f8"), count=count, offset=start)

    def uint32_array(self, count: int) -> np.ndarray:
        start = self._take(4, count) if count else self._position
        return np.frombuffer(self._data, dtype=np.dtype(self._order + "u4"), count=count, offset=start)

    def bool_array(self, count: int) -> np.ndarray:
        start = self._take(1, count)
        return np.frombuffer(self._data, dtype=np.uint8, count=count, offset=start) != 0

    def sequence_length(self, what: str, limit: int = 10_000_000) -> int:
        count = self.uint32()
        if count > limit:
            raise CdrError(f"{what} of {count} elements")
        return count

    def string(self) -> str:
        length = self.uint32()
        start = self._take(1, length)
        return bytes(self._data[start : start + max(length - 1, 0)]).decode("utf-8", errors="replace")

    def header(self) -> Stamped:
        sec, nanosec = self.int32(), self.uint32()
        return Stamped(self.string(), sec + nanosec * 1e-9)

    def pose(self) -> Pose2D:
        x, y, _z, qx, qy, qz, qw = self.float64s(7)
        return Pose2D(x, y, yaw_from_quaternion(Quaternion(qx, qy, qz, qw)))


def tf_message(data: bytes) -> list[StampedTransform]:
    """tf2_msgs/TFMessage: every transform's parent, child, stamp and planar pose."""
    reader = Reader(data)
    transforms = []
    for _ in range(reader.uint32()):
        header = reader.header()
        child = reader.string()
        transforms.append(StampedTransform(header.frame_id, child, header.stamp, reader.pose()))
    return transforms


def odometry_pose(data: bytes) -> StampedTransform:
    """nav_msgs/Odometry: frame, child frame, stamp and the planar pose (twist and covariances left unread)."""
    reader = Reader(data)
    header = reader.header()
    child = reader.string()
    return StampedTransform(header.frame_id, child, header.stamp, reader.pose())


def pose_array(data: bytes) -> tuple[Stamped, np.ndarray]:
    """geometry_msgs/PoseArray: header and an (N, 3) array of x, y, yaw."""
    reader = Reader(data)
    header = reader.header()
    count = reader.uint32()
    if count > 10_000_000:
        raise CdrError(f"PoseArray of {count} poses")
    values = reader.float64_array(7 * count).reshape(count, 7)
    qx, qy, qz, qw = values[:, 3], values[:, 4], values[:, 5], values[:, 6]
    # amr_util.geometry.yaw_from_quaternion, for every pose at once
    yaw = np.arctan2(2.0 * (qw * qz + qx * qy), qw * qw + qx * qx - qy * qy - qz * qz)
    return header, np.column_stack([values[:, 0], values[:, 1], yaw])


class PoseGraphData(NamedTuple):
    header: Stamped
    poses: np.ndarray
    """(N, 3) x, y, theta of the nodes"""
    edge_from: np.ndarray
    edge_to: np.ndarray
    loop_closure: np.ndarray
    """(M,) bool"""


def pose_graph(data: bytes) -> PoseGraphData:
    """amr_interfaces/PoseGraph (a SLAM graph: node poses as geometry_msgs/Pose2D, edges, which are loop closures)."""
    reader = Reader(data)
    header = reader.header()
    count = reader.sequence_length("PoseGraph poses")
    poses = reader.float64_array(3 * count).reshape(count, 3)
    edge_from = reader.uint32_array(reader.sequence_length("PoseGraph edge_from"))
    edge_to = reader.uint32_array(reader.sequence_length("PoseGraph edge_to"))
    loop = reader.bool_array(reader.sequence_length("PoseGraph loop_closure"))
    return PoseGraphData(header, poses, edge_from, edge_to, loop)


class FrontiersData(NamedTuple):
    header: Stamped
    centroids: np.ndarray
    """(K, 2) x, y (z dropped)"""
    sizes: np.ndarray
    chosen: int
    blacklisted: int
    state: str


def frontiers(data: bytes) -> FrontiersData:
    """amr_interfaces/Frontiers (frontier exploration's centroids, sizes, the chosen one, its state)."""
    reader = Reader(data)
    header = reader.header()
    count = reader.sequence_length("Frontiers centroids")
    centroids = reader.float64_array(3 * count).reshape(count, 3)[:, :2]
    sizes = reader.uint32_array(reader.sequence_length("Frontiers sizes"))
    chosen, blacklisted = reader.int32(), reader.uint32()
    return FrontiersData(header, centroids, sizes, chosen, blacklisted, reader.string())
