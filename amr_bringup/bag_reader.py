"""Read a rosbag2 bag (MCAP or SQLite storage) and draw it as the demo draws a run.

The bag's own message definitions decode it (rosbags' AnyReader), so a bag recorded on a real robot
with other interface versions reads too. The figure is the demo's maze picture: walls, the path
coloured by speed, the robot and its last scan, from the bag's odometry (`ground_truth` when the
simulator recorded it, else `odom`) and `scan` topics. No rclpy here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from rosbags.highlevel import AnyReader
from rosbags.rosbag2.errors import ReaderError

from amr_bringup.bag_writer import BagError, bag_directory
from amr_maps.world import World
from amr_simulation.config import LidarConfig
from amr_simulation.lidar import Lidar
from amr_simulation.render import draw_robot, draw_scan, draw_trajectory, draw_world
from amr_util.geometry import Pose2D, yaw_from_quaternion
from amr_util.robot_description import default_robot

POSE_TOPICS = ("/ground_truth", "/odom", "/odometry")
SCAN_TOPIC = "/scan"
DEFAULT_LIDAR = LidarConfig()
"""The simulator's default LiDAR (frozen: one instance serves as every default)."""


@dataclass
class Recording:
    """A bag's messages, decoded, by topic: lists of (stamp in ns, message), in stamp order."""

    topics: dict[str, list[tuple[int, object]]] = field(default_factory=dict)
    types: dict[str, str] = field(default_factory=dict)

    def count(self, topic: str) -> int:
        return len(self.topics.get(topic, ()))


def read_bag(path: str | Path, topics: tuple[str, ...] = ()) -> Recording:
    """Every message of the bag (or of `topics`), decoded with the definitions stored in it."""
    directory = bag_directory(path)
    recording = Recording()
    try:
        with AnyReader([directory]) as reader:
            connections = [c for c in reader.connections if not topics or c.topic in topics]
            for connection in connections:
                recording.topics.setdefault(connection.topic, [])
                recording.types[connection.topic] = connection.msgtype
            for connection, stamp, raw in reader.messages(connections=connections):
                message = reader.deserialize(raw, connection.msgtype)
                recording.topics[connection.topic].append((stamp, message))
    except (ReaderError, OSError) as error:
        raise BagError(f"{directory}: cannot read the bag ({error})") from error
    for messages in recording.topics.values():
        messages.sort(key=lambda item: item[0])
    return recording


def trajectory(recording: Recording, pose_topic: str | None = None) -> tuple[np.ndarray, list[Pose2D]]:
    """Rows [x, y, speed] and the poses of a nav_msgs/Odometry topic (the first of POSE_TOPICS present)."""
    topic = pose_topic or next((t for t in POSE_TOPICS if recording.count(t)), None)
    if topic is None or not recording.count(topic):
        raise BagError(
            f"no odometry to draw: none of {', '.join((pose_topic,) if pose_topic else POSE_TOPICS)} "
            "has messages in the bag"
        )
    poses, rows = [], []
    for _, message in recording.topics[topic]:
        p, q = message.pose.pose.position, message.pose.pose.orientation
        twist = message.twist.twist.linear
        poses.append(Pose2D(p.x, p.y, yaw_from_quaternion(q)))
        rows.append((p.x, p.y, math.hypot(twist.x, twist.y)))
    return np.array(rows, dtype=float), poses


def render_bag(
    path: str | Path,
    png: str | Path,
    world: World,
    pose_topic: str | None = None,
    lidar: LidarConfig = DEFAULT_LIDAR,
    robot_radius: float = default_robot().radius,
    max_speed: float = default_robot().max_linear_speed,
    dpi: int = 120,
) -> Path:
    """The demo's maze figure of a recorded run: `world` under the bag's path, robot and last scan."""
    recording = read_bag(path)
    rows, poses = trajectory(recording, pose_topic)
    figure = Figure(figsize=(7.0, 6.0), layout="constrained")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    draw_world(ax, world)
    lines = draw_trajectory(ax, rows, max_speed)
    draw_robot(ax, poses[-1], robot_radius)
    if recording.count(SCAN_TOPIC):
        _, scan = recording.topics[SCAN_TOPIC][-1]
        ranges = np.asarray(scan.ranges, dtype=float)
        fan = LidarConfig(
            beams=ranges.size,
            angle_min=scan.angle_min,
            fov=min(scan.angle_increment * ranges.size, 2 * math.pi),  # float32 steps overshoot 2 pi
            range_min=scan.range_min,
            range_max=scan.range_max,
            x=lidar.x,
            y=lidar.y,
        )
        sensor = Lidar(fan, caster=None, rng=None).sensor_pose(poses[-1])  # the mounting only: no casting
        draw_scan(ax, sensor, np.where(ranges > scan.range_max, np.inf, ranges), fan)
    seconds = (
        max(s for m in recording.topics.values() for s, _ in m)
        - min(s for m in recording.topics.values() for s, _ in m)
    ) * 1e-9
    ax.set_title(f"{world.name}   recorded {seconds:.1f} s   {sum(map(len, recording.topics.values()))} messages")
    figure.colorbar(lines, ax=ax, label="speed [m/s]", shrink=0.8)
    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(png, dpi=dpi)
    return png
