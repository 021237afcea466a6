"""Pictures of a simulation with matplotlib (Agg, no pyplot state): reusable per Axes.

draw_* functions draw onto an Axes the caller owns, so other figures (a demo
comparing runs, say) can compose them; save_png makes a whole figure of one
simulator.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle, FancyArrow, Polygon

from amr_maps.world import World
from amr_simulation.config import LidarConfig
from amr_util.geometry import Pose2D

if TYPE_CHECKING:
    from amr_simulation.simulator import Simulator

WALL_COLOUR = "0.25"
ROBOT_COLOUR = "tab:blue"
HIT_COLOUR = "tab:red"
START_COLOUR = "tab:green"
GOAL_COLOUR = "tab:orange"
SPEED_MAP = "viridis"
MARGIN = 0.2
"""m of floor shown around the world's solids."""


def draw_world(ax: Axes, world: World) -> None:
    """Solids, the start pose (green arrow) and the goal region (orange disc)."""
    for polygon in world.polygons:
        ax.add_patch(Polygon(polygon, closed=True, facecolor=WALL_COLOUR, edgecolor=WALL_COLOUR, linewidth=0.5))
    x, y, theta = world.start
    ax.add_patch(
        FancyArrow(x, y, 0.15 * math.cos(theta), 0.15 * math.sin(theta), width=0.02, color=START_COLOUR, zorder=3)
    )
    if world.goal is not None:
        ax.add_patch(Circle((world.goal.x, world.goal.y), world.goal.radius, color=GOAL_COLOUR, alpha=0.4, zorder=1))
    xmin, ymin, xmax, ymax = world.bounds
    ax.set_xlim(xmin - MARGIN, xmax + MARGIN)
    ax.set_ylim(ymin - MARGIN, ymax + MARGIN)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def draw_trajectory(ax: Axes, trajectory: np.ndarray, max_speed: float) -> LineCollection:
    """The path as segments coloured by speed (rows [x, y, speed]); returns them for a colorbar."""
    points = trajectory[:, :2]
    segments = np.stack([points[:-1], points[1:]], axis=1)
    lines = LineCollection(segments, cmap=SPEED_MAP, linewidths=2.0, zorder=2)
    lines.set_array(trajectory[1:, 2])
    lines.set_clim(0.0, max_speed)
    ax.add_collection(lines)
    return lines


def draw_robot(ax: Axes, pose: Pose2D, radius: float) -> None:
    """The footprint and a heading line."""
    ax.add_patch(Circle((pose.x, pose.y), radius, facecolor="none", edgecolor=ROBOT_COLOUR, linewidth=1.5, zorder=4))
    ax.plot(
        [pose.x, pose.x + radius * math.cos(pose.theta)],
        [pose.y, pose.y + radius * math.sin(pose.theta)],
        color=ROBOT_COLOUR, linewidth=1.5, zorder=4,
    )


def draw_scan(ax: Axes, sensor: Pose2D, ranges: np.ndarray, lidar: LidarConfig) -> None:
    """The LiDAR returns as dots in the world frame (no-return beams are left out)."""
    angles = sensor.theta + lidar.angle_min + lidar.angle_increment * np.arange(ranges.size)
    valid = np.isfinite(ranges)
    ax.scatter(
        sensor.x + ranges[valid] * np.cos(angles[valid]),
        sensor.y + ranges[valid] * np.sin(angles[valid]),
        s=4, color=HIT_COLOUR, zorder=5, linewidths=0,
    )


def draw_simulation(ax: Axes, sim: "Simulator") -> LineCollection:
    """World, trajectory, robot and last scan of a simulator; returns the trajectory lines."""
    draw_world(ax, sim.world)
    lines = draw_trajectory(ax, sim.trajectory, sim.config.robot.max_linear)
    draw_robot(ax, sim.pose, sim.config.robot.radius)
    draw_scan(ax, sim.sensor_pose, np.asarray(sim.ranges), sim.lidar)
    goal = "  goal reached" if sim.goal_reached else ""
    ax.set_title(f"{sim.world.name}   t = {sim.time:.2f} s   collisions: {sim.collisions}{goal}")
    return lines


def save_png(sim: "Simulator", path: str | Path, dpi: int = 120) -> Path:
    """A PNG of the simulator with a speed colour bar."""
    path = Path(path)
    figure = Figure(figsize=(7.0, 6.0), layout="constrained")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    lines = draw_simulation(ax, sim)
    figure.colorbar(lines, ax=ax, label="speed [m/s]", shrink=0.8)
    figure.savefig(path, dpi=dpi)
    return path
