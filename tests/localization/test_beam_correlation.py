"""The beams' weights of the correlation model (beam_correlation.py): beams on one spot count as one, beams far apart
each count, a scan's count of independent beams does not grow with its angular resolution."""

import math

import numpy as np
import pytest

from amr_localization.beam_correlation import beam_weights, beams_in_view, correlation_sums, independent_count
from amr_localization.scan_beams import Beams


def beams_at(points: np.ndarray, returned=None) -> Beams:
    points = np.asarray(points, dtype=float)
    ranges = np.hypot(points[:, 0], points[:, 1])
    angles = np.arctan2(points[:, 1], points[:, 0])
    returned = np.ones(len(points), dtype=bool) if returned is None else np.asarray(returned)
    return Beams(ranges, angles, returned, 30.0, np.arange(len(points)), 0.01)


def test_beams_on_one_spot_count_once_and_beams_far_apart_each_count():
    spot = beams_at(np.tile([[2.0, 0.0]], (10, 1)))
    assert beams_in_view(beam_weights(spot, 0.5)) == pytest.approx(1.0)
    apart = beams_at([[20.0 * math.cos(a), 20.0 * math.sin(a)] for a in np.linspace(0.0, 3.0, 6)])
    assert beams_in_view(beam_weights(apart, 0.5)) == pytest.approx(6.0, abs=1e-6)


def test_two_beams_share_by_their_correlation():
    d, length = 0.3, 0.5
    pair = beams_at([[3.0, 0.0], [3.0, d]])
    np.testing.assert_allclose(beam_weights(pair, length), 1.0 / (1.0 + math.exp(-d / length)))


def test_a_wall_counts_the_same_whatever_the_angular_resolution():
    def wall(count):
        y = np.linspace(-3.0, 3.0, count)
        return beams_in_view(beam_weights(beams_at(np.column_stack([np.full(count, 2.0), y])), 0.5))

    assert wall(360) == pytest.approx(wall(180), rel=0.02)
    assert wall(360) < 10.0, "6 m of wall with a 0.5 m correlation length is a handful of independent beams"


def test_beams_without_a_return_weigh_nothing_and_length_zero_makes_every_beam_independent():
    beams = beams_at([[2.0, 0.0], [2.0, 0.01], [5.0, 0.0]], returned=[True, True, False])
    weights = beam_weights(beams, 0.5)
    assert weights[2] == 0.0 and weights[0] == pytest.approx(weights[1]) and 0.5 < weights[0] < 0.51
    np.testing.assert_array_equal(beam_weights(beams, 0.0), [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(correlation_sums(np.zeros((3, 2)), 0.0), np.ones(3))


def test_the_compiled_sums_are_the_pairwise_formula_and_the_count_is_their_inverse_sum():
    points = np.random.default_rng(3).uniform(-5.0, 5.0, (200, 2))
    distance = np.hypot(*(points[:, None, :] - points[None, :, :]).transpose(2, 0, 1))
    np.testing.assert_allclose(correlation_sums(points, 0.7), np.exp(-distance / 0.7).sum(axis=1), rtol=1e-12)
    assert independent_count(points, 0.7) == pytest.approx(np.sum(1.0 / np.exp(-distance / 0.7).sum(axis=1)))
    assert independent_count(np.zeros((0, 2)), 0.7) == 0.0 and independent_count(points, 0.0) == 200.0
