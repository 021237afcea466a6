"""amr_maps.window_search.window_modes: several well-separated best poses within a window (the front end's rival
modes): both walls of a pair found, the match's own place excluded, headings kept within the window."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_maps.occupancy_grid import OCCUPIED, OccupancyGrid
from amr_maps.scan_matcher import CorrelativeMatcher, ScoreMap
from amr_maps.window_search import window_modes


def _walls(xs) -> CorrelativeMatcher:
    """A likelihood field of 3 m walls along y at each x of xs and a floor along x at y = -1.5 (it pins the scan
    along the walls), 5 cm cells, x -2..6, y -3..3."""
    data = np.zeros((120, 160), dtype=np.int8)
    ys = np.arange(-1.5, 1.5, 0.025)
    for x in xs:
        data[np.floor((ys + 3.0) / 0.05).astype(int), int(math.floor((x + 2.025) / 0.05))] = OCCUPIED
    data[int(math.floor(1.525 / 0.05)), :] = OCCUPIED
    return CorrelativeMatcher(ScoreMap.from_occupancy(OccupancyGrid(data, 0.05, (-2.0, -3.0, 0.0)), sigma=0.075))


WALL = np.vstack(
    [
        np.column_stack([np.full(100, 2.0), np.linspace(-1.4, 1.4, 100)]),  # a wall 2 m ahead
        np.column_stack([np.linspace(0.0, 1.9, 60), np.full(60, -1.5)]),  # the floor on the right
    ]
)


def test_both_walls_of_a_pair_are_modes_and_the_best_is_matchs():
    matcher = _walls((2.0, 2.6))
    found = window_modes(matcher, WALL, np.zeros(3), 1.0, 0.2, count=3, min_score=0.5, min_separation=0.2)
    assert found.exhaustive and found.nodes > 0
    xs = sorted(round(float(m.pose[0]), 2) for m in found.matches[:2])
    assert abs(xs[0]) <= 0.05 and abs(xs[1] - 0.6) <= 0.05, [m.pose for m in found.matches]
    assert all(abs(m.pose[2]) < 0.05 for m in found.matches[:2])
    best = matcher.match(WALL, np.zeros(3), 1.0, 0.2, refine=False)
    assert found.matches[0].score == pytest.approx(best.score, abs=1e-9)


def test_the_excluded_disc_and_the_windows_headings_are_kept_out():
    matcher = _walls((2.0, 2.6))
    found = window_modes(
        matcher, WALL, np.zeros(3), 1.0, 0.2, count=5, min_score=0.5, min_separation=0.2, exclude=(0.0, 0.0, 0.2)
    )
    assert found.matches, "the second wall is a mode outside the disc"
    for match in found.matches:
        assert math.hypot(match.pose[0], match.pose[1]) >= 0.2 - 1e-9
        assert abs(match.pose[2]) <= 0.2 + 1e-9
    assert abs(found.matches[0].pose[0] - 0.6) <= 0.05
    # a lone wall: nothing scores half as well outside the match's own disc but its own slope along the wall,
    # which the search keeps within the window's headings
    lone = window_modes(_walls((2.0,)), WALL, np.zeros(3), 1.0, 0.2, count=5, min_score=0.9, exclude=(0, 0, 0.2))
    assert all(abs(m.pose[0]) < 0.1 for m in lone.matches), [m.pose for m in lone.matches]


def test_bad_arguments_are_named():
    matcher = _walls((2.0,))
    with pytest.raises(ValueError, match="count"):
        window_modes(matcher, WALL, np.zeros(3), 1.0, 0.2, count=0)
    with pytest.raises(ValueError, match="prior"):
        window_modes(matcher, WALL, [np.nan, 0.0, 0.0], 1.0, 0.2)
    empty = window_modes(matcher, np.zeros((0, 2)), np.zeros(3), 1.0, 0.2)
    assert empty.matches == [] and empty.nodes == 0
