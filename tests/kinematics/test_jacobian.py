"""Geometric Jacobian against finite differences, for every convention incl. prismatic."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support.kinematics import prismatic_modified_chain

from amr_kinematics.chain import Chain
from amr_kinematics.transforms import rotation_error, xyz_rpy_matrix


def finite_difference_jacobian(chain, q, h=1e-6):
    """Columns (dp/dq_i, w_i) by central differences; w from the rotation between q -/+ h."""
    jac = np.zeros((6, chain.n))
    for i in range(chain.n):
        dq = np.zeros(chain.n)
        dq[i] = h
        plus, minus = chain.fk(q + dq).tool, chain.fk(q - dq).tool
        jac[:3, i] = (plus[:3, 3] - minus[:3, 3]) / (2 * h)
        jac[3:, i] = np.array(rotation_error(*minus[:3, :3].ravel(), *plus[:3, :3].ravel())) / (2 * h)
    return jac


def planar_with_base_and_tool() -> Chain:
    return Chain(
        "pl",
        "planar",
        ["a", "b", "c"],
        ["prismatic", "revolute", "prismatic"],
        theta=[0.3, 0.0, -0.4],
        a=[0.1, 0.2, 0.05],
        lower=[0.0, -3.0, 0.0],
        upper=[1.0, 3.0, 1.0],
        base=xyz_rpy_matrix([0.5, -0.2, 0.1, 0.0, 0.0, 0.7]),
        tool=xyz_rpy_matrix([0.03, 0.01, 0.0, 0.0, 0.0, 0.2]),
    )


CHAIN_NAMES = ["ur5", "panda", "arm5", "manipulator3", "ull5", "ull3", "rr2"]


@pytest.mark.parametrize("name", CHAIN_NAMES)
def test_shipped_chains_against_finite_differences(chain_set, name):
    chain = chain_set[name].chain
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = rng.uniform(chain.lower, chain.upper)
        np.testing.assert_allclose(chain.jacobian(q), finite_difference_jacobian(chain, q), atol=1e-6)


@pytest.mark.parametrize("build", [prismatic_modified_chain, planar_with_base_and_tool])
@given(data=st.data())
@settings(max_examples=20, deadline=None)
def test_mixed_prismatic_chains_against_finite_differences(build, data):
    chain = build()
    q = np.array([data.draw(st.floats(lo, hi)) for lo, hi in zip(chain.lower, chain.upper, strict=True)])
    np.testing.assert_allclose(chain.jacobian(q), finite_difference_jacobian(chain, q), atol=1e-6)


def test_prismatic_columns_are_pure_translation(chain_set):
    chain = chain_set["manipulator3"].chain  # standard DH: joints 1 and 3 slide
    jac = chain.jacobian(chain_set["manipulator3"].home)
    for column in (0, 2):
        np.testing.assert_allclose(jac[3:, column], 0.0)
        assert np.linalg.norm(jac[:3, column]) == pytest.approx(1.0)
