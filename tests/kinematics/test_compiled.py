"""The numba-compiled DLS attempt takes the steps of the Python loop."""

from __future__ import annotations

import time

import numpy as np
import pytest
from support.kinematics import random_targets

from amr_kinematics.errors import InvalidRequestError
from amr_kinematics.solvers import compiled, get_solver
from amr_kinematics.solvers.base import Request, _seed, parse_goal
from amr_kinematics.solvers.iterative import Refiner, StepSettings

pytestmark = pytest.mark.skipif(not compiled.AVAILABLE, reason="numba not installed")


def _attempts(chain, target, seed, with_orientation, step, steps):
    # no deadline to speak of: a first call may compile for seconds before the Python loop runs
    request = Request(with_orientation, 1e-9, 1e-9, steps, time.perf_counter() + 1e6, False)
    goal = parse_goal(chain, target, with_orientation)
    fast = Refiner(chain, goal, request, step)
    generic = Refiner(chain, goal, request, step)
    assert fast.compiled
    generic.compiled, generic.fast = False, None
    return fast.run(np.asarray(seed, dtype=float), steps), generic.run(np.asarray(seed, dtype=float), steps)


@pytest.mark.parametrize(
    "name, with_orientation",
    [
        ("ur5", False),
        ("ur5", True),
        ("panda", True),
        ("arm5", False),
        ("ull5", False),
        ("manipulator3", False),
        ("gen3", True),
        ("stanford", True),
        ("scara", False),
        ("snake10", True),
        ("kr5", True),
        ("puma560", True),
    ],
)
def test_compiled_attempts_match_the_python_loop(chain_set, unseen_set, name, with_orientation):
    config = {**chain_set, **unseen_set}[name]
    step = StepSettings(
        damping=1e-3, adaptive_damping=0.1, patience=0, angular_weight=0.5 if name == "panda" else None
    )  # weighted rotation rows too
    for target in random_targets(config.chain, 4, seed=len(name)):
        goal = target if with_orientation else target[: 2 if config.chain.planar else 3, 3]
        # step by step (a few steps each): over long runs near singularities rounding differences grow
        for steps in (1, 2, 4, 8, 16):
            fast, generic = _attempts(config.chain, goal, config.home, with_orientation, step, steps)
            assert fast.converged == generic.converged and fast.iterations == generic.iterations
            np.testing.assert_allclose(fast.q, generic.q, atol=1e-9)
            assert fast.score == pytest.approx(generic.score, rel=1e-6, abs=1e-18)


def test_compiled_project_update_matches_the_python_loop(chain_set):
    config = chain_set["arm5"]  # its coupled joint is overwritten after each step (seed 004)
    step = StepSettings(damping=1e-3, adaptive_damping=0.1, patience=0, coupling_update="project")
    for target in random_targets(config.chain, 4, seed=7):
        for steps in (1, 2, 4, 8, 16):
            fast, generic = _attempts(config.chain, target[:3, 3], config.home, False, step, steps)
            assert fast.converged == generic.converged and fast.iterations == generic.iterations
            np.testing.assert_allclose(fast.q, generic.q, atol=1e-9)
            assert fast.score == pytest.approx(generic.score, rel=1e-6, abs=1e-18)


@pytest.mark.parametrize("name, with_orientation", [("rr2", False), ("ull3", True), ("ur5", True), ("arm5", False)])
def test_one_call_result_matches_the_measures_of_finish(chain_set, name, with_orientation):
    """dls's first attempt reports its result from the compiled call; base.finish measures the same q."""
    from amr_kinematics.solvers import get_solver
    from amr_kinematics.solvers.base import finish

    config = chain_set[name]
    for options in ({}, {"coupling_update": "project"}):
        for target in random_targets(config.chain, 5, seed=3):
            goal = target if with_orientation else target[: 2 if config.chain.planar else 3, 3]
            result = get_solver("dls").solve(
                config.chain, goal, seed=config.home, with_orientation=with_orientation, **options
            )
            request = Request(with_orientation, 1e-5, 1e-5, 1000, time.perf_counter() + 1.0, False)
            expected = finish(
                config.chain,
                parse_goal(config.chain, goal, with_orientation),
                result.q,
                request,
                solver="dls",
                iterations=result.iterations,
                message=result.message,
            )
            assert result.success == expected.success and result.attempts >= 1
            np.testing.assert_allclose(result.reached, expected.reached, atol=1e-12)
            np.testing.assert_allclose(result.error, expected.error, atol=1e-12)
            assert result.position_error == pytest.approx(expected.position_error, abs=1e-12)
            assert result.orientation_error == pytest.approx(expected.orientation_error, abs=1e-12)


@pytest.mark.parametrize("name, with_orientation", [("ull3", True), ("ull3", False), ("ur5", True), ("ur5", False)])
def test_compiled_goal_and_seed_equal_the_python_checks(chain_set, name, with_orientation):
    """A float64 4x4 target and a float64 seed vector take one compiled call each (pose_goal,
    clamp_finite); a nested list takes the Python checks: the same goal and seed, to the bit."""
    chain = chain_set[name].chain
    rng = np.random.default_rng(7)
    for target in random_targets(chain, 20, seed=3):
        fast, generic = (
            parse_goal(chain, target, with_orientation),
            parse_goal(chain, target.tolist(), with_orientation),
        )
        assert np.array_equal(fast.position, generic.position)
        assert (fast.rotation is None) == (generic.rotation is None) == (not with_orientation)
        if with_orientation:
            assert np.array_equal(fast.rotation, generic.rotation)
        seed = rng.uniform(chain.lower - 1.0, chain.upper + 1.0)  # some values outside the limits
        assert np.array_equal(_seed(chain, seed), chain.checked_clamp(seed.tolist(), "seed"))


@pytest.mark.parametrize(
    "change, match",
    [
        (lambda pose: pose.__setitem__((0, 1), np.nan), "finite"),
        (lambda pose: pose.__setitem__((3, 3), np.inf), "finite"),
        (lambda pose: pose.__setitem__((1, 3), 2e6), r"absurd: coordinates beyond 1e\+06 m"),
        (lambda pose: pose.__setitem__((0, 0), 2.0), "rigid"),
        (lambda pose: pose.__setitem__((3, 0), 0.5), "rigid"),
    ],
)
def test_compiled_goal_refuses_what_the_python_checks_refuse(chain_set, change, match):
    chain = chain_set["ull3"].chain
    pose = np.eye(4)
    change(pose)
    for target in (pose, pose.tolist()):
        for with_orientation in (True, False):
            with pytest.raises(InvalidRequestError, match=match):
                parse_goal(chain, target, with_orientation)


@pytest.mark.parametrize(
    "seed, match",
    [
        (np.array([0.0, np.nan, 0.0]), r"seed must be finite, got \[0.0, nan, 0.0\]"),
        (np.array([0.0, 0.0, -np.inf]), "seed must be finite"),
        (np.zeros(4), "seed has 4 values, chain 'ull3' has 3 joints"),
        (np.zeros(3, dtype=np.float32) + np.float32(np.nan), "seed must be finite"),
    ],
)
def test_bad_seed_arrays_are_refused(chain_set, seed, match):
    with pytest.raises(InvalidRequestError, match=match):
        get_solver("dls").solve(chain_set["ull3"].chain, np.eye(4), seed=seed, with_orientation=True)
