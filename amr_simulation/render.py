"""Pictures of a simulation with matplotlib (Agg, no pyplot state): reusable per Axes.

draw_* functions draw onto an Axes the caller owns, so other figures (a demo
comparing runs, say) can compose them; save_png makes a whole figure of one
simulator.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

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
    from amr_simulation.fleet import Fleet
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
    """Solids, every robot's start pose (green arrow) and goal region (orange disc, named in a fleet)."""
    for polygon in world.polygons:
        ax.add_patch(Polygon(polygon, closed=True, facecolor=WALL_COLOUR, edgecolor=WALL_COLOUR, linewidth=0.5))
    for robot in world.fleet:
        x, y, theta = robot.start
        ax.add_patch(
            FancyArrow(x, y, 0.15 * math.cos(theta), 0.15 * math.sin(theta), width=0.02, color=START_COLOUR, zorder=3)
        )
        if robot.goal is not None:
            goal = robot.goal
            ax.add_patch(Circle((goal.x, goal.y), goal.radius, color=GOAL_COLOUR, alpha=0.4, zorder=1))
            if robot.name:
                ax.annotate(robot.name, (goal.x, goal.y), ha="center", va="center", fontsize=7, zorder=6)
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


def draw_robot(ax: Axes, pose: Pose2D, radius: float, colour: str = ROBOT_COLOUR) -> None:
    """The footprint and a heading line."""
    ax.add_patch(Circle((pose.x, pose.y), radius, facecolor="none", edgecolor=colour, linewidth=1.5, zorder=4))
    ax.plot(
        [pose.x, pose.x + radius * math.cos(pose.theta)],
        [pose.y, pose.y + radius * math.sin(pose.theta)],
        color=colour,
        linewidth=1.5,
        zorder=4,
    )


def draw_scan(ax: Axes, sensor: Pose2D, ranges: np.ndarray, lidar: LidarConfig, colour: str = HIT_COLOUR) -> None:
    """The LiDAR returns as dots in the world frame (no-return beams are left out)."""
    angles = sensor.theta + lidar.angle_min + lidar.angle_increment * np.arange(ranges.size)
    valid = np.isfinite(ranges)
    ax.scatter(
        sensor.x + ranges[valid] * np.cos(angles[valid]),
        sensor.y + ranges[valid] * np.sin(angles[valid]),
        s=4,
        color=colour,
        zorder=5,
        linewidths=0,
    )


def draw_simulation(ax: Axes, sim: Simulator) -> LineCollection:
    """World, trajectory, robot and last scan of a simulator; returns the trajectory lines."""
    draw_world(ax, sim.world)
    lines = draw_trajectory(ax, sim.trajectory, sim.config.robot.max_linear)
    draw_robot(ax, sim.pose, sim.config.robot.radius)
    draw_scan(ax, sim.sensor_pose, np.asarray(sim.ranges), sim.lidar)
    goal = "  goal reached" if sim.goal_reached else ""
    ax.set_title(f"{sim.world.name}   t = {sim.time:.2f} s   collisions: {sim.collisions}{goal}")
    return lines


def draw_fleet(ax: Axes, fleet: Fleet) -> LineCollection:
    """World, and per robot (one colour each) its trajectory, footprint, name and last scan; returns the
    first robot's trajectory lines."""
    draw_world(ax, fleet.world)
    radius = fleet.config.robot.radius
    lines = []
    for index, robot in enumerate(fleet.robots):
        colour = f"C{index % 10}"
        lines.append(draw_trajectory(ax, robot.trajectory, fleet.config.robot.max_linear))
        draw_robot(ax, robot.pose, radius, colour)
        draw_scan(ax, robot.sensor_pose, np.asarray(robot.ranges), fleet.lidar, colour)
        if robot.name:
            ax.annotate(
                robot.name, (robot.pose.x, robot.pose.y + 1.6 * radius), ha="center", fontsize=7, color=colour, zorder=6
            )
    hits = sum(robot.collisions for robot in fleet.robots)
    reached = sum(robot.goal_reached for robot in fleet.robots)
    ax.set_title(
        f"{fleet.world.name}   t = {fleet.time:.2f} s   {len(fleet)} robots   collisions: {hits}   "
        f"goals reached: {reached}"
    )
    return lines[0]


def save_png(
    sim: Simulator | Fleet,
    path: str | Path,
    dpi: int = 120,
    draw: Callable[[Axes, Any], LineCollection] = draw_simulation,
) -> Path:
    """A PNG of the simulator (or, with draw=draw_fleet, of a fleet) with a speed colour bar."""
    path = Path(path)
    figure = Figure(figsize=(7.0, 6.0), layout="constrained")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    lines = draw(ax, sim)
    figure.colorbar(lines, ax=ax, label="speed [m/s]", shrink=0.8)
    figure.savefig(path, dpi=dpi)
    return path
