"""Properties over random reachable targets: FK(IK(target)) meets the tolerance and
every joint vector stays within its limits.

Targets are FK of random in-limit configurations.  Solver runs use generous
timeouts (correctness, not speed: that is bench/bench_ik.py) and derandomized
examples, so a rare hard target cannot make the suite flaky.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from amr_kinematics.solvers import get_solver

SOLVE = settings(
    max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


def configuration(chain, data):
    """A random joint vector inside the limits (coupled joints derived, unclipped)."""
    q = chain.apply_coupling([data.draw(st.floats(lo, hi)) for lo, hi in zip(chain.lower, chain.upper, strict=True)])
    assume(chain.couplings_hold(q))
    return q


@pytest.mark.parametrize(
    "name, solver, with_orientation",
    [
        ("ur5", "dls", False),
        ("ur5", "dls", True),
        ("panda", "dls", False),
        ("panda", "dls", True),
        ("ur5", "pinv", False),
        ("manipulator3", "dls", False),
        ("arm5", "dls", False),
        ("ull5", "ccd", False),
        ("rr2", "analytic", False),
        ("ull3", "dls", True),
    ],
)
@given(data=st.data())
@SOLVE
def test_fk_of_ik_meets_the_tolerance(chain_set, name, solver, with_orientation, data):
    config = chain_set[name]
    chain = config.chain
    goal = chain.fk(configuration(chain, data)).tool
    target = goal if with_orientation else goal[:3, 3]
    options = {"tolerance": 1e-5, "timeout": 2.0, "max_iterations": 100_000}
    if name == "arm5":  # the reduced coupling update, not the seed's run
        options.update(tolerance=1e-6)
        result = get_solver(solver).solve(chain, target, seed=config.home, **options)
    else:
        result = config.solve(target, solver=solver, with_orientation=with_orientation, **options)
    assert result.success, result.message
    reached = chain.fk(result.q).tool
    dims = 2 if chain.planar else 3
    assert np.linalg.norm(reached[:dims, 3] - goal[:dims, 3]) <= 1e-5 + 1e-12
    if with_orientation:
        cos_angle = (np.trace(reached[:3, :3].T @ goal[:3, :3]) - 1.0) / 2.0
        assert cos_angle >= np.cos(1e-5) - 1e-12
    assert chain.within_limits(result.q)


@pytest.mark.parametrize("solver", ["dls", "pinv"])
@given(data=st.data())
@SOLVE
def test_limits_never_violated_whatever_the_request(chain_set, solver, data):
    name = data.draw(st.sampled_from(["panda", "ur5", "manipulator3", "arm5", "ull3"]))
    config = chain_set[name]
    chain = config.chain
    seed = np.array(data.draw(st.lists(st.floats(-20.0, 20.0), min_size=chain.n, max_size=chain.n)))
    target = np.array(data.draw(st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3)))
    result = config.solve(target, solver=solver, seed=seed, timeout=0.01, record_history=True)
    assert chain.within_limits(result.q)
    assert all(chain.within_limits(record.q) for record in result.history)
    assert np.all(np.isfinite(result.q)) and np.isfinite(result.position_error)
