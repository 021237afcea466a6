"""A numpy ray caster for a fan of beams against a world's faces: no pymunk, usable by any package.

The simulator's LiDAR uses it (amr_simulation also has a pymunk caster that gives the same ranges),
the beam model of the particle filter predicts ranges with it. It returns, per beam, the distance
from the origin to the first solid face along the beam, +inf when there is none; a hit beyond
max_range is either +inf or its distance (callers compare with the range anyway). The beams are
angles phi_i = phi_0 + i * increment (world frame, i = 0 .. count - 1). Faces are rows
[x1, y1, x2, y2] with the solid on the left (amr_maps.world.World.faces).
"""

from __future__ import annotations

import numpy as np

from amr_util.geometry import TWO_PI

GRAZING = 1e-12
"""Smallest cos(beam, inward normal) kept: below it a beam runs along the face."""


def _period(increment: float, count: int) -> float:
    """Beams per full turn; exactly count when the fan closes the circle."""
    turn = TWO_PI / increment
    return float(count) if abs(turn - count) < 1e-9 * count else turn


class NumpyRayCaster:
    """All beams against all faces in a few array operations.

    Instead of testing every beam against every face, each face visible from
    the origin is swept in angle: the beams between the angles of its two end
    points are exactly the ones that hit its line within the face. For those
    (beam, face) pairs the hit distance is

        t = d / cos(phi_i - chi)

    with d the distance from the origin to the face's line and chi the
    direction of its inward normal. The work is one pass over the faces near
    the origin plus one per (beam, face) pair, which grows with how many faces
    a beam crosses rather than with the number of faces times beams.
    Faces whose back is towards the origin are skipped: a beam leaving the
    origin meets a solid's front face first.
    numpy calls cost about a microsecond each whatever their size here, so the
    code keeps their number low rather than their arrays small.
    """

    def __init__(self, faces: np.ndarray) -> None:
        faces = np.asarray(faces, dtype=float)
        ax, ay, bx, by = faces.T
        length = np.hypot(bx - ax, by - ay)
        nx, ny = (by - ay) / length, (ax - bx) / length  # outward: right of a counter-clockwise edge
        # distance from p to the face's line, positive in front: [nx, ny, -n.a] . [px, py, 1]
        self._line = np.stack([nx, ny, -(nx * ax + ny * ay)], axis=1)
        self._inward = np.arctan2(-ny, -nx)  # the direction of a beam hitting the face head-on
        self._ends = np.stack([np.stack([ax, bx]), np.stack([ay, by])])  # [x or y, end a or b, face]
        self._box = np.stack([np.minimum(ax, bx), np.minimum(ay, by), np.maximum(ax, bx), np.maximum(ay, by)])
        self._lower = (float(self._box[0].min()), float(self._box[1].min()))
        self._upper = (float(self._box[2].max()), float(self._box[3].max()))
        self._turns: dict[tuple[float, int], np.ndarray] = {}
        self._empty: dict[int, np.ndarray] = {}

    def cast(self, x: float, y: float, phi0: float, increment: float, count: int, max_range: float) -> np.ndarray:
        """Distances per beam, +inf for no hit; hits beyond max_range may be returned as they are."""
        ranges = self._no_hits(count)
        distance = self._line @ (x, y, 1.0)
        keep = distance > 0.0  # faces turned towards the origin ...
        if (
            self._lower[0] < x - max_range or self._lower[1] < y - max_range
            or self._upper[0] > x + max_range or self._upper[1] > y + max_range
        ):  # ... and, when the world outgrows the range, within a square of half side max_range
            box = self._box
            keep &= (
                (box[0] < x + max_range) & (box[1] < y + max_range)
                & (box[2] > x - max_range) & (box[3] > y - max_range)
            )
        index = keep.nonzero()[0]
        if index.size == 0:
            return ranges
        # Seen from the origin, a front face runs clockwise from end a to end b: it covers
        # the beam positions k in [k_b, k_a], k = ((angle - phi0) mod 2 pi) / increment.
        ends = self._ends[:, :, index]
        k_a, k_b = np.mod(np.arctan2(ends[1] - y, ends[0] - x) - phi0, TWO_PI) / increment
        turns = self._period_offsets(increment, count)
        k_a = k_b + np.mod(k_a - k_b, turns[1, 0])
        # Beam j sits at k = j and, one turn on, at k = j + period: a face straddling
        # k = 0 covers beams ceil(k_b) .. count - 1 and 0 .. floor(k_a - period).
        first = np.ceil(np.maximum(k_b - turns, 0.0))
        counts = np.maximum(np.minimum(np.floor(k_a - turns), count - 1) - first + 1.0, 0.0).astype(np.intp).ravel()
        total = int(counts.sum())
        if total == 0:
            return ranges
        # Flatten the (face, beam) pairs, face by face: pair p is beam[p] against face f(p).
        ends_at = counts.cumsum()
        beam = np.arange(total) - (ends_at - counts - first.ravel().astype(np.intp)).repeat(counts)
        heading = np.concatenate([phi0 - self._inward[index]] * 2).repeat(counts) + increment * beam
        distance = np.concatenate([distance[index]] * 2).repeat(counts)
        np.minimum.at(ranges, beam, distance / np.maximum(np.cos(heading), GRAZING))
        return ranges

    def _no_hits(self, count: int) -> np.ndarray:
        """A fresh all-+inf result (copying a cached one is the cheapest way to make it)."""
        if count not in self._empty:
            self._empty[count] = np.full(count, np.inf)
        return self._empty[count].copy()

    def _period_offsets(self, increment: float, count: int) -> np.ndarray:
        """[[0], [period]]: the k offsets of a beam's first and second turn (cached)."""
        key = (increment, count)
        if key not in self._turns:
            self._turns[key] = np.array([[0.0], [_period(increment, count)]])
        return self._turns[key]
