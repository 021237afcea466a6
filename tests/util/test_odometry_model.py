"""amr_util.geometry's odometry motion model parts: the first-order propagation every prior shares, and the turn off
the line of travel, one number or many."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_util.geometry import odometry_covariance, off_line, wrap_angle

RNG = np.random.default_rng(37)


@pytest.mark.parametrize(
    ("rot1", "trans", "variances"),
    [
        (0.0, 1.0, (1e-4, 4e-4, 1e-4)),  # straight ahead: along x the translation's, across y the first turn's
        (0.7, 2.5, (4e-4, 1e-4, 9e-4)),  # a long step off to the left
        (-2.8, 0.4, (1e-4, 1e-4, 1e-4)),  # nearly backwards
        (0.3, 0.0, (1e-4, 4e-4, 1e-4)),  # a turn on the spot: the position errs only along the translation
    ],
)
def test_the_propagated_covariance_is_the_spread_of_the_poses_the_noisy_motions_reach(rot1, trans, variances):
    draws = RNG.standard_normal((200_000, 3)) * np.sqrt(variances)
    heading = rot1 + draws[:, 0]
    length = trans + draws[:, 1]
    ends = np.column_stack(
        [length * np.cos(heading), length * np.sin(heading), wrap_angle(heading + draws[:, 2] - rot1)]
    )
    sampled = np.cov(ends.T)
    expected = odometry_covariance(rot1, trans, variances)
    scale = np.sqrt(np.outer(np.diag(sampled), np.diag(sampled))) + 1e-9
    assert np.all(np.abs(expected - sampled) <= 0.02 * scale + 1e-7)
    assert np.allclose(expected, expected.T)


def test_a_turn_off_the_line_of_travel_is_the_same_for_one_angle_and_for_many():
    angles = np.array([0.0, 0.2, -0.2, math.pi / 2, 3.0, -3.0, math.pi, 7.0])
    many = off_line(angles)
    assert isinstance(many, np.ndarray)
    assert many == pytest.approx([off_line(float(a)) for a in angles], abs=1e-12)
    # reversing is no half turn: 3 rad off the way on is pi - 3 off the line
    assert off_line(3.0) == pytest.approx(math.pi - 3.0)
    assert isinstance(off_line(0.5), float)
