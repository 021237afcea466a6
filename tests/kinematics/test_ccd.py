"""CCD on the ULL report's planar robots (seed 000, section 3.3)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.ull_figures import FIGURE_3_4, FIGURE_3_5

from amr_kinematics.errors import SolverNotApplicableError
from amr_kinematics.solvers import get_solver
from amr_kinematics.ull_json import load_ull_json

EPSILON = 0.01  # the report's convergence threshold, in its length units


def ccd(chain, q0, target, **kwargs):
    """The report's method: a single descent (no restarts)."""
    return get_solver("ccd").solve(
        chain,
        target,
        seed=q0,
        tolerance=EPSILON,
        max_iterations=100,
        timeout=1.0,
        record_history=True,
        restarts=False,
        **kwargs,
    )


@pytest.mark.parametrize("target", [(10.0, 10.0), (-20.0, -20.0)])
def test_five_joint_robot_reaches_the_report_targets(target):
    chain, q0 = load_ull_json(FIGURE_3_5)
    result = ccd(chain, q0, target)
    assert result.success, result.message
    assert result.position_error <= EPSILON
    assert result.iterations <= 10  # the report: 2 and 5 iterations
    np.testing.assert_allclose(chain.fk(result.q).position[:2], target, atol=EPSILON)


def test_three_joint_robot_reports_the_closest_point():
    # report figure 3.11: no convergence; theta1 = 0.4, L2 = 2, theta3 = 0.716, distance 3.09524
    chain, q0 = load_ull_json(FIGURE_3_4)
    result = ccd(chain, q0, (10.0, 10.0))
    assert not result.success
    assert "no convergence" in result.message
    assert result.q[0] == pytest.approx(0.4)
    assert result.q[1] == pytest.approx(2.0)
    assert result.q[2] == pytest.approx(0.716, abs=5e-4)
    assert result.position_error == pytest.approx(3.09524, abs=5e-5)
    origins = chain.fk(result.q).origins
    np.testing.assert_allclose(origins[1, :2], [4.605, 1.947], atol=5e-4)  # the report's (01)0
    np.testing.assert_allclose(origins[2, :2], [6.447, 2.726], atol=5e-4)  # (02)0


def test_shipped_metre_chains_behave_the_same(chain_set):
    far = chain_set["ull3"].solve([0.1, 0.1])
    assert not far.success and far.position_error == pytest.approx(0.0309524, abs=5e-7)
    for target in ([0.1, 0.1], [-0.2, -0.2]):
        near = chain_set["ull5"].solve(target)
        assert near.success and near.position_error <= 1e-4


def test_joints_are_visited_from_tip_to_base():
    # one iteration on a 2R arm: the tip joint turns first, so the base joint ends the sweep
    from amr_kinematics.chain import Chain

    chain = Chain(
        "rr",
        "planar",
        ["a", "b"],
        ["revolute", "revolute"],
        theta=[0, 0],
        a=[1.0, 1.0],
        lower=[-3.0, -3.0],
        upper=[3.0, 3.0],
    )
    result = get_solver("ccd").solve(chain, (0.0, 1.5), seed=[0.0, 0.0], max_iterations=1, record_history=True)
    q = result.history[1].q
    # tip joint first: from (2, 0) it aims the tip at the target around (1, 0)
    assert q[1] == pytest.approx(math.atan2(1.5, -1.0))
    tip = chain.fk(q).position
    # then the base joint aligns the whole arm with the target direction
    assert math.atan2(tip[1], tip[0]) == pytest.approx(math.atan2(1.5, 0.0))


def test_prismatic_values_are_never_wrapped_and_limits_hold():
    chain, q0 = load_ull_json(FIGURE_3_5)
    result = ccd(chain, q0, (-20.0, -20.0))
    assert result.q[1] > math.pi or result.q[4] > math.pi  # lengths well beyond pi stay lengths
    for record in result.history:
        assert chain.within_limits(record.q)
        revolute = ~chain.prismatic
        assert np.all(np.abs(record.q[revolute]) <= math.pi + 1e-12)


def test_seed_outside_limits_is_clamped():
    chain, q0 = load_ull_json(FIGURE_3_4)  # L2 = 5 starts above its limit of 2
    result = ccd(chain, q0, (10.0, 10.0))
    assert result.history[0].q[1] == 2.0


@pytest.mark.parametrize(
    "name, kwargs, match",
    [
        ("ur5", {}, "planar"),
        ("arm5", {}, "planar"),
        ("ull5", {"with_orientation": True}, "orientation"),
    ],
)
def test_ccd_refuses_what_it_cannot_do(chain_set, name, kwargs, match):
    target = np.eye(4) if kwargs else [0.1, 0.1, 0.1]
    with pytest.raises(SolverNotApplicableError, match=match):
        get_solver("ccd").solve(chain_set[name].chain, target, **kwargs)
