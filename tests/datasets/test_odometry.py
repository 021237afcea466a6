"""Odometry synthesized from reference poses: exact without noise, seeded, and the scale error, heading bias and
noise of the model visible in the statistics over many seeds."""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest
from support.carmen_logs import SHARED, square_path

from amr_datasets.carmen import read_carmen
from amr_datasets.odometry import OdometryNoiseModel, increments, synthesize_odometry
from amr_util.geometry import relative_pose

SEEDS = 400


def straight(count: int, step: float = 1.0) -> np.ndarray:
    return np.column_stack([step * np.arange(count), np.zeros(count), np.zeros(count)])


def relative_steps(poses: np.ndarray) -> np.ndarray:
    return np.array([relative_pose(a, b) for a, b in pairwise(poses)])


@pytest.mark.parametrize(
    "poses",
    [square_path(40), np.array([[1.0, 2.0, 3.0], [1.0, 2.0, -3.0], [0.5, 2.0, -3.0], [0.5, 2.5, 1.0]])],
    ids=["square", "turns, reverse"],
)
def test_the_perfect_model_reproduces_every_increment(poses):
    odometry = synthesize_odometry(poses, OdometryNoiseModel.perfect())
    assert odometry.shape == poses.shape and tuple(odometry[0]) == (0.0, 0.0, 0.0)
    np.testing.assert_allclose(relative_steps(odometry), relative_steps(poses), atol=1e-12)


def test_the_same_seed_gives_the_same_odometry_and_another_seed_another():
    poses = square_path(30)
    np.testing.assert_array_equal(synthesize_odometry(poses, seed=4), synthesize_odometry(poses, seed=4))
    assert not np.allclose(synthesize_odometry(poses, seed=4), synthesize_odometry(poses, seed=5))


def test_scale_error_and_heading_bias_show_in_the_mean_over_many_seeds():
    poses = straight(21)  # 20 m in 1 m steps
    noise = OdometryNoiseModel()  # 5 % noise, +1 % scale, 0.5 deg/m
    finals = np.array([synthesize_odometry(poses, noise, seed)[-1] for seed in range(SEEDS)])
    reported = np.array([increments(synthesize_odometry(poses, noise, seed))[:, 1].sum() for seed in range(SEEDS)])
    assert reported.mean() / 20.0 == pytest.approx(1.01, abs=0.002)
    assert finals[:, 2].mean() == pytest.approx(math.radians(0.5) * 20.0, abs=0.06)  # 10 deg of drift
    assert finals[:, 1].mean() > 0.5  # drifting left (positive bias) bends the path left


def test_the_noise_is_the_models_standard_deviation():
    poses = straight(2)  # one 1 m step, no turn: trans sigma alpha3 * 1 m, rotation sigmas alpha2 * 1 m
    noise = OdometryNoiseModel(0.0, 0.1, 0.05, 0.0, 0.0, 0.0)
    steps = np.array([increments(synthesize_odometry(poses, noise, seed))[0] for seed in range(2000)])
    assert steps[:, 1].std() == pytest.approx(0.05, rel=0.1) and steps[:, 1].mean() == pytest.approx(1.0, abs=0.005)
    assert steps[:, 0].std() == pytest.approx(0.1, rel=0.1) and steps[:, 2].std() == pytest.approx(0.1, rel=0.1)


def test_a_turn_on_the_spot_gets_rotation_noise_only():
    poses = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    noise = OdometryNoiseModel(0.05, 0.0, 0.0, 0.0, 0.0, 0.0)
    odometry = np.array([synthesize_odometry(poses, noise, seed)[-1] for seed in range(500)])
    assert np.abs(odometry[:, :2]).max() == 0.0
    assert odometry[:, 2].std() == pytest.approx(0.05, rel=0.15)


@pytest.mark.parametrize("field, value", [("alpha1", -0.1), ("scale_error", -1.0), ("heading_bias", math.nan)])
def test_a_bad_model_is_refused(field, value):
    with pytest.raises(ValueError, match=field):
        OdometryNoiseModel(**{field: value})


@pytest.mark.skipif(SHARED is None, reason="no copy of shared/data/carmen on this machine")
def test_odometry_of_a_shipped_log_drifts_as_modelled():
    poses = read_carmen(SHARED / "intel-corrected.log.gz").poses()
    exact = synthesize_odometry(poses, OdometryNoiseModel.perfect())
    np.testing.assert_allclose(relative_steps(exact), relative_steps(poses), atol=1e-9)
    noisy = synthesize_odometry(poses, seed=1)
    gap = np.hypot(*(noisy[-1, :2] - exact[-1, :2]))
    assert gap > 1.0  # ~500 m driven: the noisy odometry is far off by the end
