"""NumpyRayCaster.cast_many, compiled after numpy's arctan2, against the all-numpy formulation it replaced: the same
ranges bit for bit for one fan and for many (a filter's particles), full and partial fans, worlds that outgrow the
range and origins outside the walls."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from amr_maps.raycast import NumpyRayCaster, beams_per_turn
from amr_maps.world import load_world
from amr_util.geometry import TWO_PI

WORLDS = Path(__file__).resolve().parents[2] / "config" / "worlds"


def numpy_cast_many(caster, x, y, phi0, increment, count, max_range):
    """The numpy formulation (fan_spans and a per-pair sweep), kept here as the reference."""
    ranges = np.full((len(x), count), np.inf)
    distance = np.empty((len(x), len(caster._line)))
    for row, (px, py) in enumerate(zip(x.tolist(), y.tolist(), strict=True)):
        distance[row] = caster._line @ (px, py, 1.0)
    keep = distance > 0.0
    (xmin, ymin), (xmax, ymax) = caster._lower, caster._upper
    outgrown = np.array(
        [
            xmin < px - max_range or ymin < py - max_range or xmax > px + max_range or ymax > py + max_range
            for px, py in zip(x.tolist(), y.tolist(), strict=True)
        ]
    )
    box = caster._box
    near = (
        (box[0] < x[:, None] + max_range)
        & (box[1] < y[:, None] + max_range)
        & (box[2] > x[:, None] - max_range)
        & (box[3] > y[:, None] - max_range)
    )
    keep &= near | ~outgrown[:, None]
    origin, index = keep.nonzero()
    ends = caster._ends[:, :, index]
    start = phi0[origin]
    k_a, k_b = np.mod(np.arctan2(ends[1] - y[origin], ends[0] - x[origin]) - start, TWO_PI) / increment
    turns = np.array([[0.0], [beams_per_turn(increment, count)]])
    k_a = k_b + np.mod(k_a - k_b, turns[1, 0])
    first = np.ceil(np.maximum(k_b - turns, 0.0))
    counts = np.maximum(np.minimum(np.floor(k_a - turns), count - 1) - first + 1.0, 0.0)
    headings = np.concatenate([start - caster._inward[index]] * 2)
    distances = np.concatenate([distance[origin, index]] * 2)
    rows = np.concatenate([origin] * 2)
    for item, (lo, n) in enumerate(zip(first.ravel().astype(int), counts.ravel().astype(int), strict=True)):
        for beam in range(lo, lo + n):  # math.cos: libm's, as the compiled sweep's (numpy's may be SIMD's)
            hit = distances[item] / max(math.cos(headings[item] + increment * beam), 1e-12)
            ranges[rows[item], beam] = min(ranges[rows[item], beam], hit)
    return ranges


@pytest.mark.parametrize("world", ["inner_maze", "hard_maze", "twin_rooms"])
@pytest.mark.parametrize(
    ("origins", "beams", "max_range", "full"),
    [(1, 240, 3.5, True), (1, 360, 0.8, True), (200, 60, 3.5, True), (20, 90, 2.0, False)],
)
def test_cast_many_equals_the_numpy_formulation(world, origins, beams, max_range, full):
    world = load_world(WORLDS / f"{world}.yaml")
    caster = NumpyRayCaster(world.faces)
    rng = np.random.default_rng(beams)
    xmin, ymin, xmax, ymax = world.bounds
    increment = 2.0 * math.pi / beams if full else 0.02
    for _ in range(5):
        x, y = rng.uniform(xmin - 1.0, xmax + 1.0, origins), rng.uniform(ymin - 1.0, ymax + 1.0, origins)
        phi0 = rng.uniform(-7.0, 7.0, origins)
        got = caster.cast_many(x, y, phi0, increment, beams, max_range)
        assert np.isfinite(got).any()
        np.testing.assert_array_equal(got, numpy_cast_many(caster, x, y, phi0, increment, beams, max_range))
