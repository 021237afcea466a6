"""The demo's pictures (matplotlib Agg, no pyplot state): wall distance over time and arms converging."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle

TARGET_STYLE = dict(marker="*", s=160, color="tab:red", zorder=5)


def _figure(size=(7.0, 5.0)) -> Figure:
    figure = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def _iteration_colours(count: int) -> np.ndarray:
    return colormaps["viridis"](np.linspace(0.0, 1.0, max(count, 2)))


def wall_distance_figure(
    path: Path, times: Sequence[float], distances: Sequence[float], target: float, not_following: Sequence[bool]
) -> Path:
    """Distance to the followed wall over time against its target; shaded where the controller is not
    holding it (turning at a corner, searching, stabilizing)."""
    figure = _figure((9.0, 4.0))
    ax = figure.add_subplot()
    t = np.asarray(times)
    d = np.where(np.isfinite(distances), distances, np.nan)
    ax.plot(t, d, linewidth=1.0, label="distance to the followed wall")
    ax.axhline(target, color="tab:red", linestyle="--", label=f"target {target:.2f} m")
    shade = np.asarray(not_following, dtype=bool)
    if shade.any():
        ax.fill_between(
            t, 0, 1, where=shade, transform=ax.get_xaxis_transform(), color="0.85", label="not following", step="mid"
        )
    ax.set_ylim(0.0, max(0.6, 2.5 * target))
    ax.set_xlabel("simulated time [s]")
    ax.set_ylabel("distance [m]")
    ax.legend(loc="upper right")
    figure.savefig(path, dpi=110)
    return path


def arm_iterations_figure(path: Path, origins: Sequence[np.ndarray], target: Sequence[float], title: str) -> Path:
    """A 3D arm (rows of joint origins, base first) drawn at every iteration, early ones pale."""
    figure = _figure((7.0, 6.0))
    ax = figure.add_subplot(projection="3d")
    for k, (points, colour) in enumerate(zip(origins, _iteration_colours(len(origins)), strict=True)):
        p = np.asarray(points)
        ax.plot(
            p[:, 0],
            p[:, 1],
            p[:, 2],
            "-o",
            color=colour,
            markersize=3,
            linewidth=1.5,
            alpha=0.35 + 0.65 * k / max(len(origins) - 1, 1),
            label=f"iteration {k}" if k in (0, len(origins) - 1) else None,
        )
    ax.scatter(*target, **TARGET_STYLE, label="target")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(title)
    ax.legend(loc="upper left")
    figure.savefig(path, dpi=110)
    return path


def planar_iterations_figure(path: Path, origins: Sequence[np.ndarray], target: Sequence[float], title: str) -> Path:
    """A planar arm at every iteration of a solver, early ones pale."""
    figure = _figure((6.5, 6.0))
    ax = figure.add_subplot()
    for k, (points, colour) in enumerate(zip(origins, _iteration_colours(len(origins)), strict=True)):
        p = np.asarray(points)
        ax.plot(
            p[:, 0],
            p[:, 1],
            "-o",
            color=colour,
            markersize=3,
            linewidth=1.5,
            label=f"iteration {k}" if k in (0, len(origins) - 1) else None,
        )
    ax.scatter(target[0], target[1], **TARGET_STYLE, label="target")
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title)
    ax.legend(loc="best")
    figure.savefig(path, dpi=110)
    return path


def path_tracking_figure(
    path: Path, waypoints: np.ndarray, origins: Sequence[np.ndarray], joints: np.ndarray, title: str
) -> Path:
    """Left: the arm along a straight-line path. Right: the joint angles, which must not jump."""
    figure = _figure((11.0, 4.8))
    arm_ax, joint_ax = figure.subplots(1, 2)
    for k, (points, colour) in enumerate(zip(origins, _iteration_colours(len(origins)), strict=True)):
        if k % max(len(origins) // 12, 1) == 0 or k == len(origins) - 1:
            p = np.asarray(points)
            arm_ax.plot(p[:, 0], p[:, 1], "-o", color=colour, markersize=3, linewidth=1.2)
    arm_ax.plot(waypoints[:, 0], waypoints[:, 1], "--", color="tab:red", label="path")
    arm_ax.set_aspect("equal")
    arm_ax.grid(True, alpha=0.3)
    arm_ax.set_xlabel("x [m]")
    arm_ax.set_ylabel("y [m]")
    arm_ax.legend()
    arm_ax.set_title(title)
    steps = np.arange(len(joints))
    for j in range(joints.shape[1]):
        joint_ax.plot(steps, np.degrees(joints[:, j]), "-o", markersize=2, label=f"q{j + 1}")
    joint_ax.set_xlabel("waypoint")
    joint_ax.set_ylabel("joint angle [deg]")
    joint_ax.grid(True, alpha=0.3)
    joint_ax.legend()
    figure.savefig(path, dpi=110)
    return path


def localization_figure(path: Path, polygons: Sequence[np.ndarray], snapshots: Sequence[tuple]) -> Path:
    """The particles over the maze at a few instants; each snapshot is (title, particles (N, 3), truth (x, y, theta),
    estimate (x, y, theta) or None)."""
    figure = _figure((4.2 * len(snapshots), 4.4))
    axes = figure.subplots(1, len(snapshots), squeeze=False)[0]
    for ax, (title, particles, truth, estimate) in zip(axes, snapshots, strict=True):
        for polygon in polygons:
            ax.fill(polygon[:, 0], polygon[:, 1], color="0.25", linewidth=0)
        ax.scatter(
            particles[:, 0],
            particles[:, 1],
            s=1.5,
            color="tab:blue",
            alpha=0.35,
            linewidths=0,
            label=f"{len(particles)} particles",
        )
        ax.plot(truth[0], truth[1], "o", color="tab:green", markersize=7, label="true pose")
        ax.arrow(truth[0], truth[1], 0.15 * np.cos(truth[2]), 0.15 * np.sin(truth[2]), color="tab:green", width=0.01)
        if estimate is not None:
            ax.plot(estimate[0], estimate[1], "x", color="tab:red", markersize=9, mew=2, label="estimate")
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=10)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.legend(loc="lower left", fontsize=7)
    figure.savefig(path, dpi=110)
    return path


def localization_error_figure(
    path: Path,
    times: Sequence[float],
    position_error: Sequence[float],
    heading_error_deg: Sequence[float],
    localized: Sequence[bool],
) -> Path:
    """The estimate's position and heading error over time; shaded while the filter says localized."""
    figure = _figure((9.0, 4.5))
    position_ax, heading_ax = figure.subplots(2, 1, sharex=True)
    t = np.asarray(times)
    shade = np.asarray(localized, dtype=bool)
    for ax, values, label in (
        (position_ax, 100.0 * np.asarray(position_error), "position error [cm]"),
        (heading_ax, np.asarray(heading_error_deg), "heading error [deg]"),
    ):
        ax.plot(t, values, linewidth=1.0)
        ax.set_yscale("log")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3, which="both")
        if shade.any():
            ax.fill_between(
                t,
                0,
                1,
                where=shade,
                transform=ax.get_xaxis_transform(),
                color="tab:green",
                alpha=0.12,
                label="localized",
                step="mid",
            )
    position_ax.legend(loc="upper right")
    heading_ax.set_xlabel("simulated time [s]")
    figure.savefig(path, dpi=110)
    return path


def navigation_figure(
    path: Path,
    polygons: Sequence[np.ndarray],
    goal,
    trajectory: np.ndarray,
    explored: np.ndarray,
    plans: Sequence[np.ndarray],
    title: str,
) -> Path:
    """Explore, localize, plan, go: the true path while exploring and after localizing, every plan, the goal."""
    figure = _figure((6.4, 5.2))
    ax = figure.subplots()
    for polygon in polygons:
        ax.fill(polygon[:, 0], polygon[:, 1], color="0.25", linewidth=0)
    if goal is not None:
        ax.add_patch(Circle((goal.x, goal.y), goal.radius, color="tab:green", alpha=0.3, label="goal"))
    for k, plan in enumerate(plans):
        if len(plan):
            ax.plot(plan[:, 0], plan[:, 1], "--", color="tab:purple", linewidth=1.2, label="plans" if k == 0 else None)
    following = np.ma.masked_where(np.repeat(explored[:, None], 2, axis=1), trajectory)
    exploring = np.ma.masked_where(np.repeat(~explored[:, None], 2, axis=1), trajectory)
    ax.plot(exploring[:, 0], exploring[:, 1], color="tab:blue", linewidth=2.0, label="not localized: wall follower")
    ax.plot(following[:, 0], following[:, 1], color="tab:orange", linewidth=2.0, label="localized: path follower")
    if (~explored).any():
        first = trajectory[int(np.argmax(~explored))]
        ax.plot(first[0], first[1], "o", color="tab:red", markersize=7, label="first localized")
    ax.plot(trajectory[0, 0], trajectory[0, 1], "s", color="tab:blue", markersize=6, label="start")
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper right", fontsize=7)
    figure.savefig(path, dpi=110)
    return path
