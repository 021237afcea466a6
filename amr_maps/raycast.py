"""A numpy ray caster for a fan of beams against a world's faces: no pymunk, usable by any package.

The simulator's LiDAR uses it (amr_simulation also has a pymunk caster that gives the same ranges),
the beam model of the particle filter predicts ranges with it. It returns, per beam, the distance
from the origin to the first solid face along the beam, +inf when there is none; a hit beyond
max_range is either +inf or its distance (callers compare with the range anyway). The beams are
angles phi_i = phi_0 + i * increment (world frame, i = 0 .. count - 1). Faces are rows
[x1, y1, x2, y2] with the solid on the left (amr_maps.world.World.faces). cast_many casts many fans
at once (a fleet's LiDARs, a filter's particles), each row bit for bit what cast would return.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from amr_util.geometry import TWO_PI

GRAZING = 1e-12
"""Smallest cos(beam, inward normal) kept: below it a beam runs along the face."""


def beams_per_turn(increment: float, count: int) -> float:
    """Beams per full turn; exactly count when the fan closes the circle."""
    turn = TWO_PI / increment
    return float(count) if abs(turn - count) < 1e-9 * count else turn


@numba.njit(cache=True)
def _facing(distance, x, y, max_range, box, lower, upper):  # pragma: no cover - compiled
    """(origin, face) index arrays of the faces in front of each origin (distance > 0) and, for an origin the
    world's box outgrows by more than max_range, within the square of half side max_range about it; row-major
    (np.nonzero's order)."""
    origins, faces = distance.shape
    origin = np.empty(0, np.intp)
    index = np.empty(0, np.intp)
    for fill in (False, True):  # count, then fill arrays of that size
        items = 0
        for row in range(origins):
            px, py = x[row], y[row]
            outgrown = (
                lower[0] < px - max_range
                or lower[1] < py - max_range
                or upper[0] > px + max_range
                or upper[1] > py + max_range
            )
            for face in range(faces):
                if not distance[row, face] > 0.0:
                    continue
                if outgrown and not (
                    box[0, face] < px + max_range
                    and box[1, face] < py + max_range
                    and box[2, face] > px - max_range
                    and box[3, face] > py - max_range
                ):
                    continue
                if fill:
                    origin[items], index[items] = row, face
                items += 1
        if not fill:
            origin = np.empty(items, np.intp)
            index = np.empty(items, np.intp)
    return origin, index


@numba.njit(cache=True)
def _sweep_items(ranges, origin, angles, start, headings, distances, increment, period):  # pragma: no cover
    """ranges[row, beam] = min(itself, d / max(cos(heading + increment * beam), GRAZING)) over the beams each
    (origin, face) item spans, from its ends' angles (angles[0]: end a, angles[1]: end b).

    The face covers the beam positions k in [k_b, k_a] (k_b in [0, period), k_a - k_b < period: beams per turn).
    Beam j sits at k = j and, one turn on, at k = j + period: an item straddling k = 0 covers beams
    ceil(k_b) .. count - 1 and 0 .. floor(k_a - period).
    """
    count = ranges.shape[1]
    for item in range(origin.size):
        k_a = ((angles[0, item] - start[item]) % TWO_PI) / increment
        k_b = ((angles[1, item] - start[item]) % TWO_PI) / increment
        k_a = k_b + (k_a - k_b) % period
        row, heading, distance = origin[item], headings[item], distances[item]
        for turn in (0.0, period):
            first = math.ceil(max(k_b - turn, 0.0))
            last = min(math.floor(k_a - turn), count - 1.0)
            for beam in range(int(first), int(max(last - first + 1.0, 0.0)) + int(first)):
                hit = distance / max(math.cos(heading + increment * beam), GRAZING)
                if hit < ranges[row, beam]:
                    ranges[row, beam] = hit


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
        self._empty: dict[tuple[int, int], np.ndarray] = {}

    def cast(self, x: float, y: float, phi0: float, increment: float, count: int, max_range: float) -> np.ndarray:
        """Distances per beam, +inf for no hit; hits beyond max_range may be returned as they are."""
        return self.cast_many(np.array([x]), np.array([y]), np.array([phi0]), increment, count, max_range)[0]

    def cast_many(
        self, x: np.ndarray, y: np.ndarray, phi0: np.ndarray, increment: float, count: int, max_range: float
    ) -> np.ndarray:
        """(N, count) distances for N fans from origins (x[n], y[n]) starting at angles phi0[n]: row n is
        cast(x[n], y[n], phi0[n], ...) bit for bit, for the cost of a few more pairs rather than N casts."""
        ranges = self._no_hits(len(x), count)
        # contiguous float64, one compiled variant (a fleet passes columns of its sensor poses)
        x, y, phi0 = (np.ascontiguousarray(values, dtype=float) for values in (x, y, phi0))
        origins = list(zip(x.tolist(), y.tolist(), strict=True))
        distance = np.empty((len(origins), len(self._line)))
        for row, (px, py) in enumerate(origins):  # a matrix-matrix product might round differently
            distance[row] = self._line @ (px, py, 1.0)
        # The faces turned towards each origin and, when the world outgrows the range, within a square of half
        # side max_range: the (origin, face) items, origin by origin.
        origin, index = _facing(distance, x, y, float(max_range), self._box, self._lower, self._upper)
        if index.size == 0:
            return ranges
        # Seen from the origin, a front face runs clockwise from end a to end b: it covers the beam positions k
        # in [k_b, k_a], k = ((angle - phi0) mod 2 pi) / increment. The angles are numpy's (its arctan2 may round
        # differently from the compiled one); the spans and hits are compiled.
        ends = self._ends[:, :, index]
        start = phi0[origin]
        # C order whatever the items' count (numpy keeps its inputs' order: one compiled variant)
        angles = np.ascontiguousarray(np.arctan2(ends[1] - y[origin], ends[0] - x[origin]))
        _sweep_items(
            ranges,
            origin,
            angles,
            start,
            start - self._inward[index],
            distance[origin, index],
            float(increment),
            self._period_offsets(increment, count)[1, 0],
        )
        return ranges

    def _no_hits(self, origins: int, count: int) -> np.ndarray:
        """A fresh all-+inf result (copying a cached one is the cheapest way to make it)."""
        if (origins, count) not in self._empty:
            self._empty[origins, count] = np.full((origins, count), np.inf)
        return self._empty[origins, count].copy()

    def _period_offsets(self, increment: float, count: int) -> np.ndarray:
        """[[0], [period]]: the k offsets of a beam's first and second turn (cached)."""
        key = (increment, count)
        if key not in self._turns:
            self._turns[key] = np.array([[0.0], [beams_per_turn(increment, count)]])
        return self._turns[key]
