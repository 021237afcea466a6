"""The best well-separated poses of a scan within a window around a prior: `CorrelativeMatcher.match`'s lattice
(whole cells within +-linear_window in x and y, angular steps within +-angular_window) searched by
`GlobalSearch`'s branch and bound, which keeps the `count` best leaves pairwise apart, over the window's cells
less an excluded disc. What a match's rival modes are made of: the second-best place near the odometry prior
(a parallel wall, the next cell of a maze) that is not the match's own slope.

Beside scan_matcher (which it builds on): `match` returns one pose over a window, `GlobalSearch` several over a
whole map at every heading; neither searches several over a window. No ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_maps.scan_matcher import (
    QUANTUM,
    CorrelativeMatcher,
    Match,
    _BranchAndBound,
    _cells,
    _floor_covariance,
    _max_pyramid,
    _window_arguments,
    _wrap,
)


@dataclass(frozen=True)
class WindowModes:
    """window_modes' answer: the modes found (best first), the branch and bound nodes scored (each one lookup per
    point: the search's work) and whether it finished within its budget."""

    matches: list[Match]
    nodes: int
    exhaustive: bool


def window_modes(
    matcher: CorrelativeMatcher,
    points: np.ndarray,
    prior,
    linear_window: float,
    angular_window: float,
    *,
    count: int = 5,
    min_score: float = 0.0,
    min_separation: float = 0.5,
    min_angle_separation: float = 0.5,
    exclude: tuple[float, float, float] | None = None,
    angular_step: float | None = None,
    max_nodes: int = 200_000,
) -> WindowModes:
    """The `count` best lattice poses (best first, unrefined: the cell lookup's score) within +-linear_window (m,
    in x and in y) and +-angular_window (rad) of prior, each scoring min_score or more, pairwise more than
    min_separation (m) or min_angle_separation (rad) apart; `exclude` (x, y, radius): no pose whose position lies
    within radius of (x, y). A budgeted search: at most max_nodes branch and bound nodes (each one lookup per
    point); `nodes` says how many were scored, `exhaustive` whether the search finished (then the modes are the
    lattice's exact best). Bad arguments: ValueError naming them."""
    points, prior = _window_arguments("window modes", points, prior, linear_window, angular_window)
    if not isinstance(count, (int, np.integer)) or isinstance(count, bool) or count < 1:
        raise ValueError(f"window modes: count must be an integer >= 1, got {count!r}")
    if not math.isfinite(min_score) or not 0.0 <= min_score <= 1.0:
        raise ValueError(f"window modes: min_score must be in 0..1, got {min_score!r}")
    if not isinstance(max_nodes, (int, np.integer)) or max_nodes < 0:
        raise ValueError(f"window modes: max_nodes must be an integer >= 0, got {max_nodes!r}")
    if len(points) == 0:
        return WindowModes([], 0, True)
    res = matcher.resolution
    step = matcher._step(points, angular_step)
    reach = int(math.ceil(linear_window / res - 1e-9))
    turns = int(math.ceil(angular_window / step - 1e-9))
    thetas = prior[2] + step * np.arange(-turns, turns + 1)
    x_ref, y_ref = prior[0] - reach * res, prior[1] - reach * res
    size = 2 * reach + 1
    mask = np.ones((size, size), dtype=bool)
    if exclude is not None:
        cx, cy, radius = (float(v) for v in exclude)
        offsets = np.arange(size) * res
        mask &= np.hypot(x_ref + offsets[None, :] - cx, y_ref + offsets[:, None] - cy) >= radius
    if not mask.any():
        return WindowModes([], 0, True)
    region = _max_pyramid(mask.astype(np.uint8), matcher.levels)
    top = min(matcher.levels - 1, max(0, math.ceil(math.log2(size))))
    span = 1 << top
    by, bx = np.nonzero(region[top][::span, ::span])
    a = np.repeat(np.arange(len(thetas)), len(bx))
    tops = np.stack([a, np.tile(bx * span, len(thetas)), np.tile(by * span, len(thetas))], axis=1).astype(np.int32)
    rows, cols = _cells(points, x_ref, y_ref, thetas, matcher.origin, res)
    min_total = int(math.ceil(min_score * len(points) * QUANTUM - 1e-6))
    search = _BranchAndBound(
        matcher,
        rows,
        cols,
        size,
        size,
        tops,
        top,
        region,
        int(count),
        max(min_total, 1),
        (min_separation / res) ** 2,
        min_angle_separation / step,
        0,  # headings are a window, not a circle: no wrap-around in the separation
    )
    search.run(int(max_nodes))
    covariance = _floor_covariance(res, step)
    modes = [
        Match(
            np.array([x_ref + x * res, y_ref + y * res, _wrap(float(thetas[k]))]),
            total / (len(points) * QUANTUM),
            search.done,
            search.nodes,
            covariance,
        )
        for k, x, y, total in search.results()
    ]
    return WindowModes(modes, int(search.nodes), bool(search.done))


__all__ = ["WindowModes", "window_modes"]
