"""A recorded run as an animated GIF: walls, the path so far (coloured by speed), the robot and its scan.

The frames sample the bag evenly in time (`frames` of them, whatever the run's length), each drawn with the
demo figure's own draw_* functions on one Agg canvas and quantized to a 64-colour palette by Pillow's fast octree,
which keeps a few hundred frames within a few MB. The scan of a frame is the last one at or before its pose.
No rclpy here.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image

from amr_bringup.bag_reader import DEFAULT_LIDAR, POSE_TOPICS, SCAN_TOPIC, read_bag, trajectory
from amr_bringup.bag_writer import BagError
from amr_maps.world import World
from amr_simulation.config import LidarConfig
from amr_simulation.lidar import Lidar
from amr_simulation.render import draw_robot, draw_scan, draw_trajectory, draw_world
from amr_util.robot_description import default_robot

COLOURS = 64


def animate_bag(
    path: str | Path,
    gif: str | Path,
    world: World,
    frames: int = 150,
    fps: float = 15.0,
    pose_topic: str | None = None,
    lidar: LidarConfig = DEFAULT_LIDAR,
    robot_radius: float = default_robot().radius,
    max_speed: float = default_robot().max_linear_speed,
    size: tuple[float, float] = (4.8, 4.4),
    dpi: int = 80,
) -> Path:
    """Write `gif` from the bag at `path`; returns its path. BagError when the bag has no odometry."""
    if frames < 1 or not fps > 0:
        raise ValueError(f"animate_bag: frames must be >= 1 and fps > 0, got {frames}, {fps}")
    recording = read_bag(path)
    rows, poses = trajectory(recording, pose_topic)
    topic = pose_topic or next(t for t in POSE_TOPICS if recording.count(t))
    pose_stamps = np.array([stamp for stamp, _ in recording.topics[topic]])
    scans = recording.topics.get(SCAN_TOPIC, [])
    scan_stamps = np.array([stamp for stamp, _ in scans])
    if len(rows) < 2:
        raise BagError(f"{path}: {topic} has {len(rows)} message(s): nothing to animate")

    figure = Figure(figsize=size)
    figure.subplots_adjust(left=0.13, right=0.97, bottom=0.11, top=0.93)  # fixed: no layout pass per frame
    canvas = FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    draw_world(ax, world)
    ax.set_title(world.name, fontsize=10)
    canvas.draw()
    background = canvas.copy_from_bbox(figure.bbox)  # walls + the path so far: each frame adds only its piece
    images, drawn = [], 0
    for index in np.unique(np.linspace(1, len(rows) - 1, frames).round().astype(int)):
        canvas.restore_region(background)
        ax.draw_artist(draw_trajectory(ax, rows[drawn : index + 1], max_speed))
        background, drawn = canvas.copy_from_bbox(figure.bbox), index
        kept = (len(ax.patches), len(ax.lines), len(ax.collections), len(ax.texts))
        draw_robot(ax, poses[index], robot_radius)
        at = np.searchsorted(scan_stamps, pose_stamps[index], side="right") - 1
        if at >= 0:
            _, scan = scans[at]
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
            sensor = Lidar(fan, caster=None, rng=None).sensor_pose(poses[index])
            draw_scan(ax, sensor, np.where(ranges > scan.range_max, np.inf, ranges), fan)
        ax.text(
            0.02,
            0.98,
            f"t = {(pose_stamps[index] - pose_stamps[0]) * 1e-9:5.1f} s",
            transform=ax.transAxes,
            va="top",
            fontsize=9,
        )
        moving = [
            artist
            for artists, keep in zip((ax.patches, ax.lines, ax.collections, ax.texts), kept, strict=True)
            for artist in list(artists)[keep:]
        ]
        for artist in moving:  # robot, scan and time: drawn on this frame only
            ax.draw_artist(artist)
            artist.remove()
        frame = Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
        images.append(frame.convert("RGB").quantize(COLOURS, method=Image.Quantize.FASTOCTREE))
    gif = Path(gif)
    gif.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(gif, save_all=True, append_images=images[1:], duration=round(1000.0 / fps), loop=0, optimize=True)
    return gif
