"""The one solver interface: registry, refusals, deadlines, limits, result fields."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from amr_kinematics.chain import Chain
from amr_kinematics.errors import InvalidRequestError, KinematicsError, SolverNotApplicableError, UnknownSolverError
from amr_kinematics.solvers import SOLVERS, applicable_solvers, get_solver, solve
from amr_kinematics.solvers.base import Request, parse_goal
from amr_kinematics.solvers.iterative import Refiner, StepSettings


def test_registry_names():
    assert set(SOLVERS) == {"ccd", "dls", "pinv", "analytic"}
    assert all(get_solver(name).name == name for name in SOLVERS)


def test_unknown_solver_is_a_catchable_error():
    with pytest.raises(UnknownSolverError, match="known"):
        get_solver("fabrik")
    assert issubclass(UnknownSolverError, SolverNotApplicableError)
    assert issubclass(SolverNotApplicableError, KinematicsError)


def test_applicable_solvers(chain_set):
    assert applicable_solvers(chain_set["rr2"].chain) == ["ccd", "dls", "pinv", "analytic"]
    assert applicable_solvers(chain_set["ur5"].chain) == ["dls", "pinv"]
    assert applicable_solvers(chain_set["ur5"].chain, with_orientation=True) == ["dls", "pinv"]
    assert applicable_solvers(chain_set["arm5"].chain, with_orientation=True) == []


@pytest.mark.parametrize(
    "name, solver, with_orientation, match",
    [
        ("arm5", "analytic", False, "planar 2R"),
        ("ull3", "analytic", False, "planar 2R"),
        ("ur5", "ccd", False, "planar"),
        ("arm5", "dls", True, "4 independent joints"),
        ("manipulator3", "pinv", True, "6 independent joints"),
        ("rr2", "dls", True, "planar"),
        ("rr2", "analytic", True, "orientation"),
    ],
)
def test_solver_not_valid_for_the_chain(chain_set, name, solver, with_orientation, match):
    with pytest.raises(SolverNotApplicableError, match=match):
        chain_set[name].solve(np.eye(4), solver=solver, with_orientation=with_orientation)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"seed": [0.0] * 5}, "6 joints"),
        ({"seed": [0.0, math.nan, 0.0, 0.0, 0.0, 0.0]}, "finite"),
        ({"target": [0.1, math.inf, 0.2]}, "finite"),
        ({"target": [0.1, 0.2]}, "shape"),
        ({"target": np.diag([2.0, 1.0, 1.0, 1.0])}, "rigid"),
        ({"target": [0.1, 0.2, 0.3], "with_orientation": True}, "4x4 pose"),
        ({"tolerance": 0.0}, "tolerance"),
        ({"tolerance": math.nan}, "tolerance"),
        ({"tolerance": 1.4e154}, r"tolerance must be a finite number in \(0, 1e\+06\]"),  # tolerance ** 2 overflows
        ({"tolerance": math.inf}, "finite"),
        ({"tolerance": 1e6, "orientation_tolerance": 3.5}, r"orientation_tolerance .* \(0, 3.14159\]"),
        ({"timeout": -1.0}, "timeout"),
        ({"timeout": 3600.0}, "timeout"),
        ({"max_iterations": 0}, "max_iterations"),
        ({"max_iterations": 10**9}, "max_iterations"),
        ({"max_iterations": 2.5}, "max_iterations"),
        ({"dampng": 0.1}, "no option"),
        ({"damping": -1.0}, "damping"),
        ({"coupling_update": "both"}, "coupling_update"),
    ],
)
def test_malformed_requests_are_refused(chain_set, kwargs, match):
    kwargs = dict(kwargs)
    target = kwargs.pop("target", [0.3, 0.2, 0.4])
    with pytest.raises(InvalidRequestError, match=match):
        get_solver("dls").solve(chain_set["ur5"].chain, target, **kwargs)


@pytest.mark.parametrize("solver, options", [("dls", {}), ("pinv", {"samples": 10_000})])
def test_timeout_is_honoured(chain_set, solver, options):
    chain = chain_set["panda"].chain
    started = time.perf_counter()
    result = get_solver(solver).solve(chain, [5.0, 0.0, 0.0], max_iterations=1_000_000, timeout=0.02, **options)
    elapsed = time.perf_counter() - started
    assert not result.success and "timeout" in result.message
    assert elapsed < 0.02 + 0.5  # a deadline, checked every iteration (loose bound: shared CI machines)
    assert result.elapsed >= 0.02


def test_limits_hold_and_seeds_are_clamped(chain_set):
    config = chain_set["panda"]
    rng = np.random.default_rng(5)
    for solver in ("dls", "pinv"):
        for _ in range(5):
            seed = rng.uniform(-10.0, 10.0, size=7)  # mostly outside the limits
            target = np.eye(4)
            target[:3, 3] = rng.uniform(-1.0, 1.0, size=3)  # often unreachable
            result = config.solve(
                target, solver=solver, seed=seed, with_orientation=True, timeout=0.01, record_history=True
            )
            assert config.chain.within_limits(result.q)
            assert all(config.chain.within_limits(r.q) for r in result.history)


def slider() -> Chain:
    """A revolute base and a prismatic joint with a range longer than 2 pi."""
    return Chain(
        "slider",
        "standard_dh",
        ["turn", "slide"],
        ["revolute", "prismatic"],
        d=[0.0, 0.0],
        theta=[0.0, 0.0],
        a=[0.0, 0.0],
        alpha=[0.0, 0.0],
        lower=[-3.0, 0.0],
        upper=[3.0, 7.0],
    )


@pytest.mark.parametrize("solver", ["dls", "pinv"])
def test_prismatic_values_are_clamped_never_wrapped(solver):
    result = solve(slider(), [0.0, 0.0, 20.0], solver=solver, seed=[0.0, 6.5], timeout=0.05)
    assert not result.success
    assert result.q[1] == 7.0  # saturated at its limit, not wrapped to 7 - 2 pi


def test_planar_prismatic_clamped_never_wrapped():
    chain = Chain("pl", "planar", ["slide"], ["prismatic"], theta=[0.0], a=[0.0], lower=[0.0], upper=[7.0])
    result = solve(chain, [20.0, 0.0], seed=[6.5], timeout=0.05)
    assert result.q[0] == 7.0


def test_result_fields(chain_set):
    config = chain_set["ur5"]
    goal = config.chain.fk(np.array([0.3, -1.0, 1.2, -0.4, 0.8, 0.1])).tool
    result = config.solve(goal, with_orientation=True)
    assert result.success and result.solver == "dls" and result.message.startswith("converged")
    np.testing.assert_allclose(result.reached, config.chain.fk(result.q).tool, atol=1e-12)
    assert result.position_error <= 1e-5 and result.orientation_error <= 1e-5
    assert result.error.shape == (6,) and result.elapsed > 0.0 and result.history is None
    assert result.iterations >= 1


def test_chain_defaults_fill_empty_arguments(chain_set):
    config = chain_set["arm5"]
    result = config.solve([0.053, 0.0478, 0.0], solver="", seed=[], tolerance=0.0, max_iterations=0, timeout=0.0)
    assert result.iterations == 9  # home seed, axis tolerance, seed 004 options
    tight = config.solve([0.053, 0.0478, 0.0], tolerance=1e-4)  # an explicit tolerance replaces the axis bounds
    assert tight.success and tight.position_error <= 1e-4 and tight.iterations > 9


def test_planar_yaw_target(chain_set):
    config = chain_set["ull3"]
    q = np.array([0.2, 0.01, 1.0])
    result = config.solve(config.chain.fk(q).tool, solver="dls", with_orientation=True, seed=[0.1, 0.015, 0.5])
    assert result.success and result.orientation_error <= 1e-5 and result.error.shape == (3,)


def _histories(chain, target, seed, with_orientation):
    """Iterates from the fast path and the generic numpy path on the same goal."""
    request = Request(with_orientation, 1e-9, 1e-9, 50, time.perf_counter() + 10.0, True)
    goal = parse_goal(chain, target, with_orientation)
    out = []
    for fast in (True, False):
        refiner = Refiner(chain, goal, request, StepSettings(damping=1e-3, adaptive_damping=0.1))
        assert refiner.fast is not None
        if not fast:
            refiner.fast = None
        refiner.run(np.asarray(seed, dtype=float), 50)
        out.append(np.array([r.q for r in refiner.history]))
    return out


@pytest.mark.parametrize(
    "name, joints, with_orientation",
    [
        ("panda", [1.0, 0.5, -1.0, -1.5, 0.5, 2.0, 0.0], False),
        ("panda", [1.0, 0.5, -1.0, -1.5, 0.5, 2.0, 0.0], True),
        ("arm5", [0.5, 0.3, -0.4, 0.9, 0.0], False),  # reduced coupling columns
        ("ull5", [1.0, 0.1, -2.0, 0.5, 0.3], False),  # planar: zero z row
        ("manipulator3", [0.02, 1.0, 0.08, -0.5], False),  # prismatic joints
    ],
)
def test_fast_paths_take_the_same_steps_as_the_numpy_path(chain_set, name, joints, with_orientation):
    config = chain_set[name]
    goal = config.chain.fk(config.chain.apply_coupling(joints)).tool
    fast, generic = _histories(config.chain, goal if with_orientation else goal[:3, 3], config.home, with_orientation)
    assert len(fast) == len(generic) > 3
    np.testing.assert_allclose(fast, generic, atol=1e-9)


def test_solvers_can_be_shared_between_threads(chain_set):
    """The node answers requests from several threads with the same solver objects."""
    from concurrent.futures import ThreadPoolExecutor

    def work(name: str) -> list[bool]:
        config = chain_set[name]
        rng = np.random.default_rng(len(name))
        outcomes = []
        for _ in range(30):
            goal = config.chain.fk(rng.uniform(config.chain.lower, config.chain.upper)).tool
            result = config.solve(goal, with_orientation=True, timeout=1.0)
            outcomes.append(result.success and np.allclose(config.chain.fk(result.q).tool, goal, atol=1e-4))
        return outcomes

    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(work, ["ur5", "panda", "ur5", "panda"]))
    assert all(all(outcomes) for outcomes in results)
