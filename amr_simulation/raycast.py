"""The pymunk ray caster: one segment query per beam against the simulator's physics space.

It returns what amr_maps.raycast.NumpyRayCaster returns for the same world (per beam, the distance to
the first solid face, +inf for none; tests check they agree); the simulator uses the numpy one by
default and this one when asked (lidar `method: pymunk`). cast_discs adds the discs of a fleet's other
robots to the numpy caster's ranges.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

from amr_maps.raycast import beams_per_turn


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


def cast_discs(
    ranges: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    phi0: np.ndarray,
    increment: float,
    max_range: float,
    centres: np.ndarray,
    radius: float,
    skip: np.ndarray,
) -> None:
    """Lower ranges (N, count) in place where the fans of NumpyRayCaster.cast_many meet discs.

    Origin n sees every disc (centres (M, 2), all of `radius`) but disc skip[n] (-1: none), the way a
    robot's LiDAR sees the other robots and not itself. A disc at distance d and bearing beta spans
    the beams within asin(radius / d) of beta; such a beam at angle phi hits it at

        t = d cos(phi - beta) - sqrt(radius^2 - d^2 sin^2(phi - beta))

    (0 for an origin inside the disc). The work grows with the (beam, disc) pairs, as for faces; it
    is one compiled loop (numba, imported on a fleet's first scan: a one-robot simulator never needs it).
    """
    from amr_simulation.disc_sweep import sweep_discs

    sweep_discs(
        ranges,
        np.ascontiguousarray(x, dtype=float),
        np.ascontiguousarray(y, dtype=float),
        np.ascontiguousarray(phi0, dtype=float),
        float(increment),
        beams_per_turn(increment, ranges.shape[1]),
        float(max_range),
        np.ascontiguousarray(centres, dtype=float).reshape(-1, 2),
        float(radius),
        np.ascontiguousarray(skip, dtype=np.intp),
    )
