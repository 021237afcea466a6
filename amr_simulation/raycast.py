"""The pymunk ray caster: one segment query per beam against the simulator's physics space.

It returns what amr_maps.raycast.NumpyRayCaster returns for the same world (per beam, the distance to
the first solid face, +inf for none; tests check they agree); the simulator uses the numpy one by
default and this one when asked (lidar `method: pymunk`). cast_discs adds the discs of a fleet's other
robots to the numpy caster's ranges.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pymunk

from amr_maps.raycast import beams_per_turn
from amr_util.geometry import TWO_PI


class PymunkRayCaster:
    """One space.segment_query_first per beam: simple, about 3 us a beam."""

    def __init__(self, space: pymunk.Space, shape_filter: pymunk.ShapeFilter) -> None:
        self._space = space
        self._filter = shape_filter

    def cast(self, x: float, y: float, phi0: float, increment: float, count: int, max_range: float) -> np.ndarray:
        ranges = np.full(count, np.inf)
        query = self._space.segment_query_first
        for i in range(count):
            phi = phi0 + i * increment
            end = (x + max_range * math.cos(phi), y + max_range * math.sin(phi))
            hit = query((x, y), end, 0.0, self._filter)
            if hit is not None:
                ranges[i] = hit.alpha * max_range
        return ranges


def cast_discs(ranges: np.ndarray, x: np.ndarray, y: np.ndarray, phi0: np.ndarray, increment: float,
               max_range: float, centres: np.ndarray, radius: float, skip: np.ndarray) -> None:
    """Lower ranges (N, count) in place where the fans of NumpyRayCaster.cast_many meet discs.

    Origin n sees every disc (centres (M, 2), all of `radius`) but disc skip[n] (-1: none), the way a
    robot's LiDAR sees the other robots and not itself. A disc at distance d and bearing beta spans
    the beams within asin(radius / d) of beta; such a beam at angle phi hits it at

        t = d cos(phi - beta) - sqrt(radius^2 - d^2 sin^2(phi - beta))

    (0 for an origin inside the disc). The work grows with the (beam, disc) pairs, as for faces; it
    is one compiled loop (numba), since N x M pairs of numpy calls would cost more than the hits.
    """
    _sweep_discs(ranges, np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(y, dtype=float),
                 np.ascontiguousarray(phi0, dtype=float), float(increment), beams_per_turn(increment, ranges.shape[1]),
                 float(max_range), np.ascontiguousarray(centres, dtype=float).reshape(-1, 2), float(radius),
                 np.ascontiguousarray(skip, dtype=np.intp))


@numba.njit(cache=True)
def _sweep_discs(ranges, x, y, phi0, increment, period, max_range, centres, radius, skip):  # pragma: no cover
    count = ranges.shape[1]
    for origin in range(x.size):
        for disc in range(centres.shape[0]):
            if disc == skip[origin]:
                continue
            dx, dy = centres[disc, 0] - x[origin], centres[disc, 1] - y[origin]
            distance = math.hypot(dx, dy)
            if distance - radius >= max_range:
                continue
            start = phi0[origin] - math.atan2(dy, dx)  # the first beam's angle from the bearing
            half = math.asin(radius / distance) if distance > radius else math.pi
            k_lo = ((-start - half) % TWO_PI) / increment
            k_hi = k_lo + 2.0 * half / increment
            for turn in (0.0, period):  # beam j sits at k = j and, one turn on, at k = j + period
                first = max(math.ceil(k_lo - turn), 0)
                last = min(math.floor(k_hi - turn), count - 1)
                for beam in range(first, last + 1):
                    angle = start + increment * beam
                    across = distance * math.sin(angle)
                    hit = max(distance * math.cos(angle) - math.sqrt(max(radius * radius - across * across, 0.0)), 0.0)
                    if hit < ranges[origin, beam]:
                        ranges[origin, beam] = hit
