"""Pseudo-inverse with Latin-hypercube multi-start (seed 003)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from amr_kinematics.errors import InvalidRequestError
from amr_kinematics.solvers import get_solver, latin_hypercube
from amr_kinematics.solvers.base import MAX_TARGET_DISTANCE


@given(st.integers(1, 40), st.integers(1, 7), st.integers(0, 2**32 - 1))
@settings(max_examples=40)
def test_latin_hypercube_has_one_sample_per_stratum(samples, dims, seed):
    lower, upper = -np.arange(1, dims + 1, dtype=float), np.arange(1, dims + 1, dtype=float) * 2
    points = latin_hypercube(np.random.default_rng(seed), lower, upper, samples)
    assert points.shape == (samples, dims)
    assert np.all(points >= lower) and np.all(points <= upper)
    strata = np.floor((points - lower) / (upper - lower) * samples).astype(int)
    for column in strata.T:
        assert sorted(column) == list(range(samples))


def test_solves_ur5_position(chain_set):
    # timeout=1.0, not ur5's 5 ms budget, which a loaded CI core can stall past
    config = chain_set["ur5"]
    target = config.chain.fk(np.array([0.4, -1.2, 1.0, -0.5, 1.2, 0.3])).position
    result = config.solve(target, solver="pinv", timeout=1.0)
    assert result.success and result.position_error <= 1e-5
    assert config.chain.within_limits(result.q)


def test_without_samples_only_the_seed_is_refined(chain_set):
    config = chain_set["panda"]
    target = config.chain.fk(config.home + 0.05).position
    result = get_solver("pinv").solve(config.chain, target, seed=config.home, samples=0, timeout=1.0)
    assert result.success and result.attempts == 1


def test_candidates_are_tried_best_first(chain_set):
    config = chain_set["ur5"]
    target = config.chain.fk(np.array([2.0, -2.0, 2.0, 1.0, -1.0, 2.0])).position
    result = get_solver("pinv").solve(
        config.chain, target, seed=config.home, samples=16, timeout=1.0, record_history=True
    )
    starts = [r for r in result.history if r.iteration == 0]
    errors = [r.position_error for r in starts]
    assert errors == sorted(errors)


def test_unreachable_returns_the_best_candidate(chain_set):
    config = chain_set["ur5"]
    result = get_solver("pinv").solve(config.chain, [3.0, 0.0, 0.5], seed=config.home, timeout=0.05)
    assert not result.success and "timeout: best of" in result.message
    assert result.attempts > 9  # new hypercubes were drawn while time was left
    assert config.chain.within_limits(result.q)
    assert result.position_error == pytest.approx(np.linalg.norm([3.0, 0.0, 0.5] - result.reached[:3, 3]))
    home_error = np.linalg.norm([3.0, 0.0, 0.5] - config.chain.fk(config.home).position)
    assert result.position_error < home_error  # the best candidate, not the seed


def test_smaller_gain_takes_more_steps(chain_set):
    config = chain_set["panda"]
    target = config.chain.fk(config.home + 0.2).position
    solver = get_solver("pinv")
    full = solver.solve(config.chain, target, seed=config.home, samples=0, timeout=1.0, candidate_iterations=200)
    half = solver.solve(
        config.chain, target, seed=config.home, samples=0, timeout=1.0, candidate_iterations=200, gain=0.5, patience=0
    )
    assert full.success and half.success and half.iterations > full.iterations


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize(
    ("name", "solver", "with_orientation"),
    [
        ("ur5", "pinv", False),
        ("ur5", "dls", False),
        ("ur5", "pinv", True),
        ("ur5", "dls", True),
        ("rr2", "pinv", False),
        ("rr2", "dls", False),
        ("rr2", "ccd", False),
        ("rr2", "analytic", False),
    ],
)
def test_far_targets_are_unreachable_without_overflow_and_absurd_ones_refused(
    chain_set, name, solver, with_orientation
):
    config, solve = chain_set[name], get_solver(solver).solve

    def goal(distance):
        pose = np.eye(4)
        pose[:3, 3] = [distance, -distance, distance]
        return pose if with_orientation else pose[: 2 if config.chain.planar else 3, 3]

    result = solve(
        config.chain, goal(MAX_TARGET_DISTANCE), seed=config.home, with_orientation=with_orientation, timeout=0.2
    )
    assert not result.success and config.chain.within_limits(result.q)
    with pytest.raises(InvalidRequestError, match="absurd"):
        solve(config.chain, goal(1e200), seed=config.home, with_orientation=with_orientation)
