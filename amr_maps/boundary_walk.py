"""How far an ideal wall follower walks from its start to a goal: the honest time budget of a maze.

A right-hand (left-hand) follower keeps one connected solid on its hand side and travels
along the closed curve at a fixed offset from it (amr_maps.maze_families explains why
it is one curve). The walk is measured on that curve:

* the solid is rasterised on a grid of ``resolution`` m and its distance field
  d(p) = |p - solid| computed with ``scipy.ndimage.distance_transform_edt``;
* the curve is the iso-line d = ``offset`` (``contourpy``); with the robot's radius as the
  offset it enters every corridor the robot fits in (and pieces of one solid closer than
  the robot's diameter close);
* the walking direction keeps the solid on the hand's side: with t the tangent and
  grad d pointing away from the solid, a right-hand walker has grad d on its left
  (t x grad d > 0), a left-hand walker on its right;
* the walk starts where the robot meets the curve (its nearest vertex: a follower in open
  space drives to the nearest wall) and ends at the first vertex within ``reach`` of the goal.

Walk length = |start - entry| + arc length along the curve to the goal. It is an estimate
(the real path cuts outer corners and widens inner ones, by a few per cent on a maze).
"""

from __future__ import annotations

import math

import contourpy
import numpy as np
from scipy import ndimage

from amr_util.robot_description import default_robot


class BoundaryWalk:
    """The followed solid's offset curve, ordered in the walking direction from the start's entry point."""

    def __init__(
        self,
        quads: np.ndarray,
        start: tuple[float, float],
        hand: str,
        offset: float = default_robot().radius,
        resolution: float = 0.02,
    ) -> None:
        if hand not in ("right", "left"):
            raise ValueError(f"hand must be 'right' or 'left', got {hand!r}")
        quads = np.asarray(quads, dtype=float)
        pad = offset + 4.0 * resolution
        low = np.minimum(quads.reshape(-1, 2).min(axis=0), start) - pad
        high = np.maximum(quads.reshape(-1, 2).max(axis=0), start) + pad
        xs = np.arange(low[0], high[0] + resolution, resolution)
        ys = np.arange(low[1], high[1] + resolution, resolution)
        solid = _rasterise(quads, xs, ys)
        distance = ndimage.distance_transform_edt(~solid, sampling=resolution)
        lines = contourpy.contour_generator(xs, ys, distance).lines(offset)
        closed = [line for line in lines if len(line) > 3]
        if not closed:
            raise ValueError("the followed solid has no offset curve (offset larger than the free space?)")
        origin = np.asarray(start, dtype=float)
        nearest = [float(np.min(np.hypot(*(line - origin).T))) for line in closed]
        curve = closed[int(np.argmin(nearest))]
        if np.allclose(curve[0], curve[-1]):
            curve = curve[:-1]
        # walking direction from the distance gradient at the vertices
        gy, gx = np.gradient(distance, resolution)
        col = np.clip(np.round((curve[:, 0] - xs[0]) / resolution).astype(int), 0, len(xs) - 1)
        row = np.clip(np.round((curve[:, 1] - ys[0]) / resolution).astype(int), 0, len(ys) - 1)
        tangent = np.roll(curve, -1, axis=0) - curve
        left_of_tangent = tangent[:, 0] * gy[row, col] - tangent[:, 1] * gx[row, col]
        away_on_left = np.sum(left_of_tangent) > 0.0  # the solid is on the right of this order
        if away_on_left != (hand == "right"):
            curve = curve[::-1]
        entry = int(np.argmin(np.hypot(*(curve - origin).T)))
        self.curve = np.roll(curve, -entry, axis=0)
        """the offset curve, vertex 0 the entry point, in walking order"""
        steps = np.hypot(*np.diff(np.vstack([self.curve, self.curve[:1]]), axis=0).T)
        self.arc = np.concatenate([[0.0], np.cumsum(steps)])
        """arc[k]: walk along the curve from the entry point to vertex k; arc[-1] is one full lap"""
        self.approach = float(np.hypot(*(self.curve[0] - origin)))
        """m from the start to the entry point"""

    @property
    def lap(self) -> float:
        """Length of the whole closed curve (m): no goal on it is further away than the approach plus this."""
        return float(self.arc[-1])

    def length_to(self, x: float, y: float, reach: float) -> float:
        """Walk (m) from the start to the first point of the curve within ``reach`` of (x, y); inf if none."""
        close = np.nonzero(np.hypot(self.curve[:, 0] - x, self.curve[:, 1] - y) <= reach)[0]
        return self.approach + float(self.arc[close[0]]) if len(close) else math.inf


def _rasterise(quads: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Boolean image [row = y, col = x]: cell centres within half a cell diagonal of a convex counter-clockwise quad.

    The margin keeps a 4 mm wall a connected line of cells (it thickens every solid by
    0.7 cell, which the offset absorbs).
    """
    image = np.zeros((len(ys), len(xs)), dtype=bool)
    step = xs[1] - xs[0]
    for quad in quads:
        c0, c1 = np.searchsorted(xs, quad[:, 0].min() - step), np.searchsorted(xs, quad[:, 0].max() + step)
        r0, r1 = np.searchsorted(ys, quad[:, 1].min() - step), np.searchsorted(ys, quad[:, 1].max() + step)
        gx, gy = np.meshgrid(xs[c0:c1], ys[r0:r1])
        inside = np.ones(gx.shape, dtype=bool)
        margin = step / math.sqrt(2.0)
        for (ax, ay), (bx, by) in zip(quad, np.roll(quad, -1, axis=0), strict=True):
            inside &= (bx - ax) * (gy - ay) - (by - ay) * (gx - ax) >= -margin * math.hypot(bx - ax, by - ay)
        image[r0:r1, c0:c1] |= inside
    return image
