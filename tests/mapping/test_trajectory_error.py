"""The relative displacement metric (Kümmerle et al. 2009) and the aligned absolute trajectory error, on
trajectories with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_mapping.errors import MappingError
from amr_mapping.trajectory_error import absolute_error, relative_error, relative_pairs, rigid_alignment
from amr_util.geometry import compose


def _line(count: int, step: float = 1.0) -> np.ndarray:
    return np.column_stack([np.arange(count) * step, np.zeros(count), np.zeros(count)])


def _wiggle(count: int = 40, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    poses = [np.zeros(3)]
    for _ in range(count - 1):
        poses.append(np.array(compose(poses[-1], (rng.uniform(0.3, 1.0), 0.0, rng.uniform(-0.5, 0.5)))))
    return np.array(poses)


def test_identical_trajectories_have_no_error():
    reference = _wiggle()
    rel = relative_error(reference, reference)
    ate = absolute_error(reference, reference)
    assert rel.pairs > 0
    assert rel.translation == pytest.approx(0.0, abs=1e-12) and rel.rotation_deg == pytest.approx(0.0, abs=1e-9)
    assert ate.rmse == pytest.approx(0.0, abs=1e-9)


def test_a_rigidly_moved_estimate_has_no_error_and_the_alignment_is_found():
    reference = _wiggle()
    moved = np.array([compose((2.0, -3.0, 0.7), p) for p in reference])
    rel = relative_error(moved, reference)
    assert rel.translation == pytest.approx(0.0, abs=1e-9) and rel.rotation_deg == pytest.approx(0.0, abs=1e-7)
    ate = absolute_error(moved, reference)
    assert ate.rmse == pytest.approx(0.0, abs=1e-9)
    # the alignment maps the estimate back: its inverse is the motion applied
    x, y, theta = rigid_alignment(moved, reference)
    back = np.array([compose((x, y, theta), p) for p in moved])
    assert np.allclose(back[:, :2], reference[:, :2], atol=1e-9)
    assert theta == pytest.approx(-0.7)


def test_pairs_are_those_one_to_ten_metres_of_path_apart():
    i, j = relative_pairs(_line(21), 1.0, 10.0)
    gaps = j - i
    assert gaps.min() == 1 and gaps.max() == 10
    assert len(i) == sum(21 - g for g in range(1, 11))


def test_a_scale_error_gives_the_known_relative_translation_error():
    reference = _line(21)
    estimate = _line(21, 1.1)  # every metre measured 1.1 m: a pair g metres apart is 0.1 g off
    rel = relative_error(estimate, reference)
    gaps = np.arange(1, 11)
    expected = np.sum((21 - gaps) * 0.1 * gaps) / np.sum(21 - gaps)
    assert rel.translation == pytest.approx(expected)
    assert rel.rotation_deg == pytest.approx(0.0)
    assert rel.max_translation == pytest.approx(1.0)


def test_a_heading_drift_gives_the_known_relative_rotation_error():
    reference = _line(21)
    estimate = reference.copy()
    estimate[:, 2] = np.radians(np.arange(21))  # one degree more each metre
    rel = relative_error(estimate, reference)
    gaps = np.arange(1, 11)
    assert rel.rotation_deg == pytest.approx(np.sum((21 - gaps) * gaps) / np.sum(21 - gaps))
    assert rel.max_rotation_deg == pytest.approx(10.0)


def test_absolute_error_of_radially_displaced_corners_is_the_displacement():
    corners = np.array([[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0], [1.0, -1.0, 0.0]])
    estimate = corners.copy()
    estimate[:, :2] *= 1.0 + 0.1 / math.sqrt(2.0)  # each corner 0.1 m further out: no rotation or shift helps
    ate = absolute_error(estimate, corners)
    assert ate.rmse == pytest.approx(0.1) and ate.max == pytest.approx(0.1)
    assert np.allclose(ate.alignment, 0.0, atol=1e-12)


def test_bad_inputs_are_refused():
    with pytest.raises(MappingError, match="shape"):
        relative_error(np.zeros((4, 3)), np.zeros((5, 3)))
    bad = _line(5)
    bad[2, 0] = np.nan
    with pytest.raises(MappingError, match="finite"):
        absolute_error(bad, _line(5))
    with pytest.raises(MappingError, match="no pose pair"):
        relative_error(_line(3, 0.1), _line(3, 0.1))
