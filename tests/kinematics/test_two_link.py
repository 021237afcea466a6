"""Closed-form planar 2R (seed 001): both branches, quadrants, unreachable points, paths."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_kinematics.chain import Chain
from amr_kinematics.solvers import follow_path, get_solver, two_link_branches

# seed 001, exercise 9: straight lines for l1 = l2 = 2, 100 points each
PATHS = {
    "(2,0)->(0,2)": ((2.0, 0.0), (0.0, 2.0)),
    "(1,1)->(-2,1)": ((1.0, 1.0), (-2.0, 1.0)),
    "(1,0)->(-1,0)": ((1.0, 0.0), (-1.0, 0.0)),
    "(-2,0)->(2,1)": ((-2.0, 0.0), (2.0, 1.0)),
}


@pytest.mark.parametrize("target", [(1.0, 1.0), (-1.5, 2.0), (-1.5, -2.0), (2.5, -1.0), (0.0, 3.9)])
def test_both_branches_reach_the_target_in_every_quadrant(chain_set, target):
    chain = chain_set["rr2"].chain
    branches, reachable = two_link_branches(chain, target)
    assert reachable and len(branches) == 2
    assert branches[0][1] * branches[1][1] < 0  # elbow + and elbow -
    for q in branches:  # atan2 keeps the quadrant the seed's arctan(y/x) lost
        np.testing.assert_allclose(chain.fk(q).position[:2], target, atol=1e-12)


def test_solver_picks_the_branch_nearest_the_seed(chain_set):
    chain = chain_set["rr2"].chain
    up, down = two_link_branches(chain, (1.0, 1.0))[0]
    solver = get_solver("analytic")
    np.testing.assert_allclose(solver.solve(chain, (1.0, 1.0), seed=up + 0.1).q, up)
    np.testing.assert_allclose(solver.solve(chain, (1.0, 1.0), seed=down - 0.1).q, down)


@pytest.mark.parametrize("target, reached", [((5.0, 0.0), (4.0, 0.0)), ((0.0, -6.0), (0.0, -4.0))])
def test_unreachable_is_reported_not_nan(chain_set, target, reached):
    result = chain_set["rr2"].solve(target)
    assert not result.success and "unreachable" in result.message
    assert np.all(np.isfinite(result.q))
    np.testing.assert_allclose(result.reached[:2, 3], reached, atol=1e-12)  # stretched toward it
    assert result.position_error == pytest.approx(math.dist(target, reached))


def test_too_close_folds_back():
    chain = Chain(
        "short",
        "planar",
        ["a", "b"],
        ["revolute", "revolute"],
        theta=[0.0, 0.0],
        a=[2.0, 1.0],
        lower=[-4.0, -4.0],
        upper=[4.0, 4.0],
    )
    result = get_solver("analytic").solve(chain, (0.0, 0.5))
    assert not result.success
    np.testing.assert_allclose(result.reached[:2, 3], [0.0, 1.0], atol=1e-12)


def test_offsets_and_tool_fold_into_the_angles():
    from amr_kinematics.transforms import xyz_rpy_matrix

    chain = Chain(
        "off",
        "planar",
        ["a", "b"],
        ["revolute", "revolute"],
        theta=[0.3, -0.2],
        a=[1.0, 0.8],
        lower=[-4.0, -4.0],
        upper=[4.0, 4.0],
        base=xyz_rpy_matrix([0.5, 0.2, 0.0, 0.0, 0.0, 0.4]),
        tool=xyz_rpy_matrix([0.1, 0.2, 0.0, 0.0, 0.0, 0.0]),
    )
    for q in two_link_branches(chain, (0.7, 1.6))[0]:
        np.testing.assert_allclose(chain.fk(q).position[:2], (0.7, 1.6), atol=1e-12)


def test_branches_outside_limits_are_left_out():
    chain = Chain(
        "lim",
        "planar",
        ["a", "b"],
        ["revolute", "revolute"],
        theta=[0.0, 0.0],
        a=[1.0, 1.0],
        lower=[-3.0, 0.0],
        upper=[3.0, 3.0],
    )
    branches, reachable = two_link_branches(chain, (1.0, 1.0))
    assert reachable and len(branches) == 1 and branches[0][1] > 0


@pytest.mark.parametrize("name", list(PATHS))
def test_straight_paths_never_jump(chain_set, name):
    chain = chain_set["rr2"].chain
    (x0, y0), (x1, y1) = PATHS[name]
    points = np.column_stack([np.linspace(x0, x1, 100), np.linspace(y0, y1, 100)])
    path, reachable = follow_path(chain, points)
    assert reachable.all()
    tips = np.array([chain.fk(q).position[:2] for q in path])
    np.testing.assert_allclose(tips, points, atol=1e-9)
    # continuity: no branch switch and no 2 pi wrap between neighbouring points
    assert np.abs(np.diff(path, axis=0)).max() < 0.25
    assert all(chain.within_limits(q) for q in path)


def test_path_through_the_origin_keeps_moving_the_elbow(chain_set):
    # on (1,0)->(-1,0) the folded arm passes the origin: the elbow goes past pi
    # (continued, not wrapped) instead of the shoulder flipping by pi
    path, _ = follow_path(chain_set["rr2"].chain, np.column_stack([np.linspace(1, -1, 100), np.zeros(100)]))
    assert np.abs(np.diff(path[:, 0])).max() < 0.25
    assert np.abs(path[:, 1]).max() > math.pi - 0.05
