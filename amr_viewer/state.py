"""What the viewer knows of each robot, as plain data the scene draws: no rclpy, no viser.

One RobotState per namespace (a fleet draws every one). Inputs arrive decoded (amr_viewer.messages, amr_viewer.cdr);
each layer keeps a version number that changes when it does, so the scene redraws only what changed. The robot is
placed through TF (map -> odom -> base_footprint; without a map -> odom, odometry is drawn as if it were the map, as
the simulator starts it), else at its ground truth; the scan through TF at the scan's frame.

A map, a SLAM pose graph or the explorer's frontiers in a frame that is not the robot's map frame, or holding a
non-finite value, is not drawn: the input raises Skipped (its `kind` says why) and the state keeps what it had.
"""

from __future__ import annotations

import bisect
import math
from collections import Counter, deque
from dataclasses import dataclass, field

import numpy as np

from amr_util.geometry import Pose2D, transform_points
from amr_util.scan import ScanData
from amr_viewer.cdr import StampedTransform
from amr_viewer.frames import TransformTree
from amr_viewer.geometry import covariance_ellipse, finite, scan_points

LAYERS = (
    "map",
    "robot",
    "truth",
    "scan",
    "particles",
    "estimate",
    "path",
    "goal",
    "world",
    "beacons",
    "trail",
    "graph",
    "frontiers",
)
TRAIL_BREAK = 0.5
"""m: a jump longer than this between two trail points (a reset, a teleport) is not drawn as a line."""
TRUTH_HISTORY = 400
"""Ground-truth poses kept by stamp, so the true-pose ring is drawn at the instant of the robot's transform."""


class Skipped(ValueError):
    """A message that is not drawn; `kind` is why: "frame" (not the map frame), "nan" (a non-finite value) or
    "malformed" (sizes or indices that do not agree)."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


@dataclass(frozen=True)
class Frames:
    """The REP 105 frame names a robot uses."""

    map: str = "map"
    odom: str = "odom"
    base: str = "base_footprint"


@dataclass(frozen=True)
class MapImage:
    """An occupancy grid as an RGB image placed in the map frame (row 0 = the grid's first row, at the origin)."""

    rgb: np.ndarray
    width: float
    """m along the grid's x"""
    height: float
    center: Pose2D
    """the image centre and the grid's yaw, in the map frame"""

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the image's corners in the map frame."""
        c, s = math.cos(self.center.theta), math.sin(self.center.theta)
        corners = [(sx * self.width / 2, sy * self.height / 2) for sx in (-1, 1) for sy in (-1, 1)]
        xs = [self.center.x + c * u - s * v for u, v in corners]
        ys = [self.center.y + s * u + c * v for u, v in corners]
        return min(xs), min(ys), max(xs), max(ys)


FREE_GRAY, OCCUPIED_GRAY, UNKNOWN_GRAY = 250, 45, 200


def map_image(width: int, height: int, resolution: float, origin: Pose2D, data) -> MapImage:
    """An OccupancyGrid's cells (row-major from cell (0, 0)) as gray levels: free light, occupied dark, unknown
    mid-gray; Skipped (a ValueError) naming what is wrong with the grid."""
    if not finite(resolution, *origin):
        raise Skipped("nan", f"map at {resolution} m per cell from {tuple(origin)}: not finite")
    if width <= 0 or height <= 0 or not resolution > 0.0:
        raise Skipped("malformed", f"map of {width} x {height} cells at {resolution} m: not drawable")
    cells = np.asarray(data, dtype=np.int16)
    if cells.size != width * height:
        raise Skipped("malformed", f"map data holds {cells.size} cells, {width} x {height} = {width * height} expected")
    cells = cells.reshape(height, width)
    known = np.clip(cells, 0, 100).astype(float) / 100.0
    gray = FREE_GRAY + (OCCUPIED_GRAY - FREE_GRAY) * known
    gray = np.where(cells < 0, UNKNOWN_GRAY, gray).astype(np.uint8)
    w, h = width * resolution, height * resolution
    c, s = math.cos(origin.theta), math.sin(origin.theta)
    center = Pose2D(origin.x + c * w / 2 - s * h / 2, origin.y + s * w / 2 + c * h / 2, origin.theta)
    return MapImage(np.repeat(gray[:, :, None], 3, axis=2), w, h, center)


@dataclass
class Scan:
    data: ScanData
    frame_id: str


@dataclass
class Estimate:
    pose: Pose2D
    covariance: tuple[float, float, float]
    """(xx, xy, yy) m^2"""
    localized: bool


@dataclass(frozen=True)
class WorldGoal:
    x: float
    y: float
    radius: float


@dataclass(frozen=True)
class PoseGraphView:
    """A SLAM pose graph as drawn: node poses and edges (node index pairs), which are loop closures."""

    poses: np.ndarray
    """(N, 3) x, y, theta in the map frame"""
    edges: np.ndarray
    """(M, 2) int"""
    loop: np.ndarray
    """(M,) bool"""

    @property
    def loop_closures(self) -> int:
        return int(self.loop.sum())

    def segments(self, loop: bool) -> np.ndarray:
        """(K, 2, 2) the sequential edges (loop False) or the loop closures (True) as segments."""
        edges = self.edges[self.loop == loop]
        return self.poses[:, :2][edges]


def pose_graph_view(poses, edge_from, edge_to, loop) -> PoseGraphView:
    """The arrays of an amr_interfaces/PoseGraph checked: Skipped for a non-finite pose ("nan"), edge arrays of
    different lengths or an edge to a node that is not there ("malformed")."""
    poses = np.array(poses, dtype=float).reshape(-1, 3)
    edge_from, edge_to = np.asarray(edge_from, dtype=np.int64).ravel(), np.asarray(edge_to, dtype=np.int64).ravel()
    loop = np.asarray(loop, dtype=bool).ravel()
    if not np.isfinite(poses).all():
        bad = int(np.flatnonzero(~np.isfinite(poses).all(axis=1))[0])
        raise Skipped("nan", f"pose graph node {bad} of {len(poses)} is {tuple(poses[bad].tolist())}: not finite")
    if not len(edge_from) == len(edge_to) == len(loop):
        raise Skipped(
            "malformed",
            f"pose graph of {len(edge_from)} edge_from, {len(edge_to)} edge_to, {len(loop)} loop_closure: "
            "one per edge expected",
        )
    edges = np.column_stack([edge_from, edge_to]).reshape(-1, 2)
    if len(edges) and (edges.min() < 0 or edges.max() >= len(poses)):
        bad = int(np.flatnonzero((edges < 0).any(axis=1) | (edges >= len(poses)).any(axis=1))[0])
        raise Skipped(
            "malformed", f"pose graph edge {bad} joins nodes {tuple(edges[bad].tolist())}: there are {len(poses)} nodes"
        )
    return PoseGraphView(poses, edges, loop)


@dataclass(frozen=True)
class FrontierView:
    """Frontier exploration's state as drawn: each frontier's centroid and size, the one driven to."""

    centroids: np.ndarray
    """(K, 2) in the map frame"""
    sizes: np.ndarray
    """(K,) cells"""
    chosen: int
    """index of the frontier driven to, -1 for none"""
    blacklisted: int
    state: str

    @property
    def chosen_centroid(self) -> np.ndarray | None:
        return self.centroids[self.chosen] if 0 <= self.chosen < len(self.centroids) else None


def frontier_view(centroids, sizes, chosen: int, blacklisted: int, state: str) -> FrontierView:
    """The fields of an amr_interfaces/Frontiers checked: Skipped for a non-finite centroid ("nan"), sizes not one
    per centroid or a chosen index that is not a frontier's ("malformed")."""
    centroids = np.array(centroids, dtype=float).reshape(-1, 2)
    sizes = np.array(sizes, dtype=np.int64).ravel()
    if not np.isfinite(centroids).all():
        bad = int(np.flatnonzero(~np.isfinite(centroids).all(axis=1))[0])
        raise Skipped("nan", f"frontier {bad} of {len(centroids)} at {tuple(centroids[bad].tolist())}: not finite")
    if len(sizes) != len(centroids):
        raise Skipped("malformed", f"{len(sizes)} frontier sizes for {len(centroids)} centroids")
    if not -1 <= chosen < len(centroids):
        raise Skipped("malformed", f"chosen frontier {chosen} of {len(centroids)}")
    return FrontierView(centroids, sizes, int(chosen), int(blacklisted), str(state))


def decimate(points: np.ndarray, limit: int) -> np.ndarray:
    """At most `limit` rows, evenly strided (deterministic: the same cloud draws the same points)."""
    if limit <= 0:
        return points[:0]
    if len(points) <= limit:
        return points
    return points[np.linspace(0, len(points) - 1, limit).round().astype(int)]


@dataclass
class Trail:
    """The path the robot took: points at least `spacing` apart, in chunks of `chunk` points so a scene can freeze
    full chunks; a NaN row marks a break (a jump longer than TRAIL_BREAK: a reset, a teleport)."""

    spacing: float = 0.02
    chunk: int = 500
    max_chunks: int = 40
    chunks: list[list[tuple[float, float]]] = field(default_factory=lambda: [[]])
    dropped: int = 0
    """chunks dropped from the front (max_chunks reached)"""

    def add(self, x: float, y: float) -> bool:
        """Add a point if it is far enough from the last; True when the trail changed."""
        if not finite(x, y):
            return False
        last = self.last()
        if last is not None:
            distance = math.hypot(x - last[0], y - last[1])
            if distance < self.spacing:
                return False
            if distance > TRAIL_BREAK:
                self._append((math.nan, math.nan))
        self._append((x, y))
        return True

    def last(self) -> tuple[float, float] | None:
        for chunk in reversed(self.chunks):
            if chunk:
                return chunk[-1] if math.isfinite(chunk[-1][0]) else None
        return None

    def _append(self, point: tuple[float, float]) -> None:
        current = self.chunks[-1]
        current.append(point)
        if len(current) >= self.chunk:
            self.chunks.append([point])  # the next chunk starts where this one ends: no gap in the line
            if len(self.chunks) > self.max_chunks:
                self.chunks.pop(0)
                self.dropped += 1

    def clear(self) -> None:
        self.dropped += len(self.chunks)
        self.chunks = [[]]


class RobotState:
    """Everything drawn for one robot namespace; inputs from the node, reads by the scene."""

    def __init__(
        self, namespace: str, frames: Frames = Frames(), max_particles: int = 1000, trail_spacing: float = 0.02
    ) -> None:
        self.namespace = namespace
        self.plain_frames = frames
        prefix = namespace.strip("/")
        self.prefixed_frames = (
            Frames(frames.map, f"{prefix}/{frames.odom}", f"{prefix}/{frames.base}") if prefix else frames
        )
        """a fleet on one shared tree (the simulator's `one_tf_tree`, as Stage's): `<name>/odom`,
        `<name>/base_footprint`"""
        self.max_particles = max_particles
        self.tree = TransformTree()
        self.versions: Counter[str] = Counter()
        self.map: MapImage | None = None
        self.truth: Pose2D | None = None
        self._truths: deque[tuple[float, Pose2D]] = deque(maxlen=TRUTH_HISTORY)
        self.base_stamp: float | None = None
        """s, the stamp of the latest transform to the robot's base frame (the instant the disc is drawn at)"""
        self.scan: Scan | None = None
        self.particles: np.ndarray = np.zeros((0, 3))
        self.particle_count = 0
        self.estimate: Estimate | None = None
        self.path: np.ndarray = np.zeros((0, 2))
        self.goal: Pose2D | None = None
        self.world_goal: WorldGoal | None = None
        self.beacons: np.ndarray = np.zeros((0, 2))
        self.trail = Trail(spacing=trail_spacing)
        self.status: dict = {}
        self.graph: PoseGraphView | None = None
        self.frontiers: FrontierView | None = None
        self.skipped: Counter[str] = Counter()
        """layer -> messages not drawn (Skipped: a wrong frame, a non-finite value, malformed)"""

    def _changed(self, *layers: str) -> None:
        for layer in layers:
            self.versions[layer] += 1

    @property
    def frames(self) -> Frames:
        """The plain REP 105 frames, or the ones prefixed by the namespace once the tree holds the robot under those
        (a fleet's one shared tree: every robot's transforms arrive on /tf, each drawn from its own frames)."""
        if (
            self.prefixed_frames is not self.plain_frames
            and self.tree.has(self.prefixed_frames.base)
            and not self.tree.has(self.plain_frames.base)
        ):
            return self.prefixed_frames
        return self.plain_frames

    @property
    def map_frames(self) -> tuple[str, ...]:
        """The frames a map, a graph or frontiers may be in: the map frame ("" is read as it, as amr_maps.messages
        reads a grid) or, in a namespace, the map frame prefixed by it."""
        prefix = self.namespace.strip("/")
        plain = self.plain_frames.map.lstrip("/")
        return ("", plain, f"{prefix}/{plain}") if prefix else ("", plain)

    def check_frame(self, frame_id: str, what: str) -> None:
        """Skipped ("frame") unless `frame_id` is one of map_frames."""
        if frame_id.lstrip("/") not in self.map_frames:
            raise Skipped("frame", f"{what} in frame {frame_id!r}, not {self.plain_frames.map!r}: not drawn")

    # -- inputs -------------------------------------------------------------------------------------------------

    def on_map(self, image: MapImage, frame_id: str = "") -> None:
        """A new map replaces the one drawn (a SLAM map grows: each /map is the whole map so far)."""
        self.check_frame(frame_id, "map")
        self.map = image
        self._changed("map")

    def on_graph(self, graph: PoseGraphView, frame_id: str = "") -> None:
        """A SLAM pose graph (amr_mapping's slam ~/graph) replaces the one drawn."""
        self.check_frame(frame_id, "pose graph")
        self.graph = graph
        self._changed("graph")

    def on_frontiers(self, frontiers: FrontierView, frame_id: str = "") -> None:
        """The explorer's frontiers (amr_mapping's explorer ~/frontiers) replace the ones drawn."""
        self.check_frame(frame_id, "frontiers")
        self.frontiers = frontiers
        self._changed("frontiers")

    def on_transforms(self, transforms: list[StampedTransform]) -> None:
        changed = False
        for transform in transforms:
            if self.tree.set(transform.parent, transform.child, transform.pose):
                changed = True
                if transform.child.lstrip("/") in (self.plain_frames.base, self.prefixed_frames.base):
                    self.base_stamp = transform.stamp
        if changed:
            self._changed("robot", "scan", "truth")
            if self.truth is None:  # no ground truth: the trail follows the robot as TF places it
                pose = self.robot_pose()
                if pose is not None and self.trail.add(pose.x, pose.y):
                    self._changed("trail")

    def on_ground_truth(self, transform: StampedTransform) -> None:
        if not finite(*transform.pose):
            return
        self.truth = transform.pose
        if self._truths and transform.stamp < self._truths[-1][0]:  # time went back (a restart): a new history
            self._truths.clear()
        self._truths.append((transform.stamp, transform.pose))
        self._changed("truth")
        if (
            self.tree.lookup(self.frames.map, self.frames.base) is None
            and self.tree.lookup(self.frames.odom, self.frames.base) is None
        ):
            self._changed("robot", "scan")  # no TF: the robot is drawn at its ground truth
        if self.trail.add(transform.pose.x, transform.pose.y):
            self._changed("trail")

    def on_scan(self, scan: Scan) -> None:
        self.scan = scan
        self._changed("scan")

    def on_particles(self, poses: np.ndarray) -> None:
        """(N, 3) x, y, yaw; non-finite rows dropped, at most max_particles kept for drawing."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        poses = poses[np.isfinite(poses).all(axis=1)]
        self.particle_count = len(poses)
        self.particles = decimate(poses, self.max_particles)
        self._changed("particles")

    def on_estimate(self, estimate: Estimate) -> None:
        if finite(*estimate.pose):
            self.estimate = estimate
            self._changed("estimate")

    def on_path(self, points: np.ndarray) -> None:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        self.path = points[np.isfinite(points).all(axis=1)]
        self._changed("path")

    def on_goal(self, pose: Pose2D) -> None:
        if finite(*pose):
            self.goal = pose
            self._changed("goal")

    def on_world(self, goal: WorldGoal | None, beacons) -> None:
        self.world_goal = goal
        self._changed("world")
        if len(beacons):
            self.on_beacons(beacons)

    def on_beacons(self, positions) -> None:
        positions = np.asarray(positions, dtype=float).reshape(-1, 2)
        positions = positions[np.isfinite(positions).all(axis=1)]
        if positions.shape != self.beacons.shape or not np.array_equal(positions, self.beacons):
            self.beacons = positions
            self._changed("beacons")

    def on_status(self, status: dict) -> None:
        if status.get("steps") == 0 and self.status.get("steps", 0) > 0:  # a reset: a new run, a new trail
            self.trail.clear()
            self._changed("trail")
        self.status = status

    # -- what is drawn ------------------------------------------------------------------------------------------

    def robot_pose(self) -> Pose2D | None:
        """base_footprint in the map: through TF, else the ground truth."""
        frames = self.frames
        pose = self.tree.lookup_or_assume(frames.map, frames.base, (frames.map, frames.odom))
        return pose if pose is not None else self.truth

    def truth_at_robot_instant(self) -> Pose2D | None:
        """The ground truth at the stamp of the robot's latest base transform (the latest truth at or before it;
        the latest of all without TF, or when the history does not reach back that far): the ring and the disc
        then show the same instant, and their distance is the localization error alone."""
        if not self._truths:
            return None
        if (
            self.base_stamp is None
            or self.tree.lookup_or_assume(self.frames.map, self.frames.base, (self.frames.map, self.frames.odom))
            is None
        ):
            return self._truths[-1][1]
        index = bisect.bisect_right([stamp for stamp, _ in self._truths], self.base_stamp) - 1
        return self._truths[index][1] if index >= 0 else self._truths[-1][1]

    def drawn_offset(self) -> float | None:
        """m between the disc (TF) and the ring (truth at the same instant); None without both or without TF."""
        pose, truth = self.robot_pose(), self.truth_at_robot_instant()
        if pose is None or truth is None or pose is self.truth:
            return None
        return math.hypot(pose.x - truth.x, pose.y - truth.y)

    def scan_in_map(self) -> np.ndarray:
        """(N, 2) scan end points in the map frame; empty when the scan's frame is not placed yet."""
        if self.scan is None:
            return np.zeros((0, 2))
        frames = self.frames
        pose = self.tree.lookup_or_assume(frames.map, self.scan.frame_id, (frames.map, frames.odom))
        if pose is None and self.truth is not None and self.scan.frame_id.lstrip("/") == frames.base:
            pose = self.truth
        if pose is None:
            return np.zeros((0, 2))
        data = self.scan.data
        return transform_points(
            pose, scan_points(data.ranges, data.angle_min, data.angle_increment, data.range_min, data.range_max)
        )

    def estimate_ellipse(self, sigmas: float = 2.0) -> np.ndarray | None:
        if self.estimate is None:
            return None
        xx, xy, yy = self.estimate.covariance
        return covariance_ellipse(self.estimate.pose.x, self.estimate.pose.y, xx, xy, yy, sigmas)

    @property
    def localized(self) -> bool | None:
        """The localizer's word (None without one)."""
        return None if self.estimate is None else self.estimate.localized

    def extent(self) -> tuple[float, float, float, float] | None:
        """(xmin, ymin, xmax, ymax) worth looking at: the map, else what is known of the robot's surroundings."""
        if self.map is not None:
            return self.map.bounds
        points = [p for p in (self.robot_pose(), self.truth) if p is not None]
        if not points:
            return None
        xs, ys = [p.x for p in points], [p.y for p in points]
        return min(xs) - 2.0, min(ys) - 2.0, max(xs) + 2.0, max(ys) + 2.0
