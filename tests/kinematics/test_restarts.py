"""Restarts: spread starts, and no step count ends a solve that still has time."""

from __future__ import annotations

import numpy as np
import pytest
from support.kinematics import random_targets

from amr_kinematics.solvers import SpreadStarts, get_solver


def test_consecutive_starts_share_one_hypercube(chain_set):
    chain = chain_set["panda"].chain
    starts = SpreadStarts(chain, np.zeros(chain.n), batch=16, random_seed=3)
    points = np.vstack([starts.take(10), starts.take(6)])  # two calls, one hypercube of 16
    strata = np.floor((points - chain.lower) / (chain.upper - chain.lower) * 16).astype(int)
    for joint in range(chain.n):  # every joint's range visited once per stratum
        assert sorted(strata[:, joint]) == list(range(16))


def test_coupled_joints_follow_the_spread_ones(chain_set):
    chain = chain_set["arm5"].chain
    for q in SpreadStarts(chain, np.zeros(chain.n), batch=8, random_seed=0).take(8):
        assert (
            chain.within_limits(q)
            and q[4] == pytest.approx(chain.couplings[0].value(q))
            or q[4] in (chain.lower[4], chain.upper[4])
        )


RESTART_BUDGET = 0.5
"""s of wall clock per solve: ten times what these solves take on a quiet machine, so that a loaded one does not end
a solve before its restarts (the claim is that restarts solve every target, not how fast: bench/bench_ik.py)."""


@pytest.mark.parametrize("solver, steps", [("dls", 6), ("pinv", 15)])  # pinv's gain 0.7 needs more steps
def test_an_iteration_cap_does_not_end_a_solve_with_time_left(chain_set, solver, steps):
    config = chain_set["panda"]
    results = [
        get_solver(solver).solve(
            config.chain, target, seed=config.home, with_orientation=True, max_iterations=steps, timeout=0.5
        )
        for target in random_targets(config.chain, 10, seed=5)
    ]
    assert all(r.success for r in results), [r.message for r in results]
    assert max(r.iterations for r in results) > steps  # several short descents, where a total cap gave up


def test_an_unreachable_target_uses_the_whole_budget(chain_set):
    result = chain_set["ur5"].solve([3.0, 0.0, 0.5], max_iterations=5, timeout=0.03)
    assert not result.success and result.message.startswith("timeout")
    assert result.elapsed >= 0.03 and result.attempts > 1


def test_ccd_solves_a_ten_joint_snake(unseen_set):
    chain = unseen_set["snake10"].chain
    targets = random_targets(chain, 40, seed=7)
    solved = sum(
        get_solver("ccd")
        .solve(chain, t[:2, 3], seed=unseen_set["snake10"].home, tolerance=1e-5, timeout=RESTART_BUDGET)
        .success
        for t in targets
    )
    assert solved == 40  # a single descent (the report's method) solved 75 % of such targets


@pytest.mark.parametrize("name", ["panda_tool", "lrmate200id"])
def test_pinv_full_pose_on_unseen_arms(unseen_set, name):
    config = unseen_set[name]
    targets = random_targets(config.chain, 25, seed=11)
    solved = sum(
        get_solver("pinv")
        .solve(config.chain, t, seed=config.home, with_orientation=True, timeout=RESTART_BUDGET)
        .success
        for t in targets
    )
    assert solved == 25  # gain 1.0 and one hypercube of candidates: 88-90 %
