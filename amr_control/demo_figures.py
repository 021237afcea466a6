"""The demo's pictures (matplotlib Agg, no pyplot state): wall distance over time and arms converging."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

TARGET_STYLE = dict(marker="*", s=160, color="tab:red", zorder=5)


def _figure(size=(7.0, 5.0)) -> Figure:
    figure = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def _iteration_colours(count: int) -> np.ndarray:
    return colormaps["viridis"](np.linspace(0.0, 1.0, max(count, 2)))


def wall_distance_figure(path: Path, times: Sequence[float], distances: Sequence[float], target: float,
                         not_following: Sequence[bool]) -> Path:
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
        ax.fill_between(t, 0, 1, where=shade, transform=ax.get_xaxis_transform(), color="0.85", label="not following",
                        step="mid")
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
    for k, (points, colour) in enumerate(zip(origins, _iteration_colours(len(origins)))):
        p = np.asarray(points)
        ax.plot(p[:, 0], p[:, 1], p[:, 2], "-o", color=colour, markersize=3, linewidth=1.5,
                alpha=0.35 + 0.65 * k / max(len(origins) - 1, 1), label=f"iteration {k}" if k in (0, len(origins) - 1) else None)
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
    for k, (points, colour) in enumerate(zip(origins, _iteration_colours(len(origins)))):
        p = np.asarray(points)
        ax.plot(p[:, 0], p[:, 1], "-o", color=colour, markersize=3, linewidth=1.5,
                label=f"iteration {k}" if k in (0, len(origins) - 1) else None)
    ax.scatter(target[0], target[1], **TARGET_STYLE, label="target")
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title)
    ax.legend(loc="best")
    figure.savefig(path, dpi=110)
    return path


def path_tracking_figure(path: Path, waypoints: np.ndarray, origins: Sequence[np.ndarray],
                         joints: np.ndarray, title: str) -> Path:
    """Left: the arm along a straight-line path. Right: the joint angles, which must not jump."""
    figure = _figure((11.0, 4.8))
    arm_ax, joint_ax = figure.subplots(1, 2)
    for k, (points, colour) in enumerate(zip(origins, _iteration_colours(len(origins)))):
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
