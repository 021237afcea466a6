"""Forward kinematics of every convention against the seeds and published figures."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support.kinematics import prismatic_modified_chain, seed004_arm
from transforms3d.quaternions import mat2quat

from amr_kinematics.chain import Chain
from amr_kinematics.errors import InvalidRequestError
from amr_kinematics.transforms import rot_x, rot_z, trans

SEED004_START = np.radians([0.0, 60.0, -40.0, -50.0, -60.0])


def test_seed004_start_pose_in_centimetres():
    # seed 004: P = A_05 at (0, 60, -40, -50, -60) deg is (11.5286, 0, 3.5402) cm
    tool = seed004_arm(scale=1.0).fk(SEED004_START).tool
    np.testing.assert_allclose(tool[:3, 3], [11.5286, 0.0, 3.5402], atol=5e-5)


def test_seed004_start_pose_in_metres(chain_set):
    tool = chain_set["arm5"].chain.fk(SEED004_START).tool
    np.testing.assert_allclose(tool[:3, 3] * 100.0, [11.5286, 0.0, 3.5402], atol=5e-5)


@given(st.lists(st.floats(-3.0, 3.0), min_size=5, max_size=5))
@settings(max_examples=30)
def test_seed004_matches_its_closed_form(q):
    # seed 004: x = c1 (L2 c2 + L3 c23 + L4 c234 + L5 c2345), y = s1 (...), z = L1 + L2 s2 + ...
    q1, q2, q3, q4, q5 = q
    sums = np.cumsum([q2, q3, q4, q5])
    reach = 5.0 * np.cos(sums).sum()
    expected = [math.cos(q1) * reach, math.sin(q1) * reach, 5.0 + 5.0 * np.sin(sums).sum()]
    np.testing.assert_allclose(seed004_arm(scale=1.0).fk(q).tool[:3, 3], expected, atol=1e-9)


def _report_matriz_t(d, th_deg, a, al_deg):
    """The ULL script's matriz_T (standard DH), angles in degrees."""
    return rot_z(math.radians(th_deg)) @ trans(z=d) @ trans(x=a) @ rot_x(math.radians(al_deg))


@given(
    st.floats(0.0, 10.0), st.floats(-180.0, 180.0), st.floats(0.0, 10.0), st.floats(-180.0, 180.0), st.floats(0.0, 90.0)
)
@settings(max_examples=30)
def test_manipulator3_matches_the_report_dh_product(chain_set, p0, p1, p2, p3, p4):
    # seed 000, figure 2.3: the eight-row table, auxiliary frame and tool row included
    d = [p0, 0, 5, p2, 0, 0, 0, 0]
    th = [-90, p1, 0, 0, p3 - 90, p4 - 90, -p4 - 90, -90]
    a = [0, 0, 0, 0, 0, 2, 2, 2]
    al = [0, -90, 0, 0, -90, 0, 0, 0]
    rows = [_report_matriz_t(d[i], th[i], a[i], al[i]) for i in range(8)]
    t04 = rows[0] @ rows[1] @ rows[2] @ rows[3] @ rows[4]
    t0ef = t04 @ rows[7]  # rows 5 and 6 are the fingers: a branch moved by p4 only
    chain = chain_set["manipulator3"].chain
    tool = chain.fk([p0 / 100.0, math.radians(p1), p2 / 100.0, math.radians(p3)]).tool
    np.testing.assert_allclose(tool[:3, :3], t0ef[:3, :3], atol=1e-9)
    np.testing.assert_allclose(tool[:3, 3] * 100.0, t0ef[:3, 3], atol=1e-9)


def test_ur5_zero_pose(chain_set):
    # at q = 0: x = a2 + a3, y = -(d4 + d6), z = d1 - d5
    tool = chain_set["ur5"].chain.fk(np.zeros(6)).tool
    np.testing.assert_allclose(tool[:3, 3], [-0.81725, -0.19145, -0.005491], atol=1e-9)


def test_panda_zero_pose_at_the_flange(chain_set):
    # at q = 0 the flange is 0.088 m forward, 0.333 + 0.316 + 0.384 - 0.107 m up, facing down
    tool = chain_set["panda"].chain.fk(np.zeros(7)).tool
    np.testing.assert_allclose(tool[:3, 3], [0.088, 0.0, 0.926], atol=1e-9)
    np.testing.assert_allclose(tool[:3, 2], [0.0, 0.0, -1.0], atol=1e-9)


def test_planar_chain_with_prismatic_joint():
    # ULL convention: revolute value is the angle, prismatic value is the length
    chain = Chain(
        "p",
        "planar",
        ["t1", "l2"],
        ["revolute", "prismatic"],
        theta=[0.0, 0.5],
        a=[1.0, 0.0],
        lower=[-3.0, 0.0],
        upper=[3.0, 2.0],
    )
    result = chain.fk([0.3, 1.5])
    expected = [math.cos(0.3) + 1.5 * math.cos(0.8), math.sin(0.3) + 1.5 * math.sin(0.8), 0.0]
    np.testing.assert_allclose(result.position, expected, atol=1e-12)
    np.testing.assert_allclose(result.origins[1], [math.cos(0.3), math.sin(0.3), 0.0], atol=1e-12)


def test_fk_gives_every_joint_origin_and_the_tool(chain_set):
    result = chain_set["ur5"].chain.fk(chain_set["ur5"].home)
    assert result.frames.shape == (7, 4, 4)
    assert result.origins.shape == (8, 3)
    np.testing.assert_allclose(result.origins[0], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(result.origins[-1], result.tool[:3, 3])
    np.testing.assert_allclose(result.origins[1], [0.0, 0.0, 0.089159], atol=1e-12)


@pytest.mark.parametrize("bad", [[0.0] * 5, [0.0] * 7, [0.0, 0.0, math.nan, 0.0, 0.0, 0.0], "abc"])
def test_fk_refuses_malformed_joint_vectors(chain_set, bad):
    with pytest.raises(InvalidRequestError):
        chain_set["ur5"].chain.fk(bad)


def _random_q(chain, rng):
    return rng.uniform(chain.lower, chain.upper)


def test_kernel_matches_reference_on_every_chain(chain_set):
    rng = np.random.default_rng(7)
    chains = [c.chain for c in chain_set.values()] + [prismatic_modified_chain()]
    for chain in chains:
        for _ in range(10):
            q = _random_q(chain, rng)
            reference = chain.fk(q).tool
            jacobian = chain.jacobian(q)
            out = chain.kernel.pose_jacobian(q.tolist())
            np.testing.assert_allclose(out[:3], reference[:3, 3], atol=1e-12, err_msg=chain.name)
            np.testing.assert_allclose(np.reshape(out[3:12], (3, 3)), reference[:3, :3], atol=1e-12)
            np.testing.assert_allclose(np.reshape(out[12], (6, chain.n)), jacobian, atol=1e-12)
            position = chain.kernel.position_jacobian(q.tolist())
            np.testing.assert_allclose(np.array(position[3:]), jacobian[:3], atol=1e-12)
            np.testing.assert_allclose(chain.kernel.position(q.tolist()), reference[:3, 3], atol=1e-12)


@given(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 0.1))
@settings(max_examples=30)
def test_quaternion_round_trip(values):
    from amr_kinematics.transforms import matrix_quaternion, quaternion_matrix

    q = np.array(values) / np.linalg.norm(values)
    rotation = quaternion_matrix(q)
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    back = np.array(matrix_quaternion(rotation))
    assert np.allclose(back, q, atol=1e-9) or np.allclose(back, -q, atol=1e-9)  # q and -q: one rotation
    w, x, y, z = mat2quat(rotation)  # transforms3d's eigen-decomposition, an independent reference
    assert back[3] >= 0.0 and np.allclose(np.abs(back), np.abs([x, y, z, w]), atol=1e-9)


@pytest.mark.parametrize("quaternion", [(0.0, 0.0, 0.0, 0.0), (math.nan, 0.0, 0.0, 1.0)])
def test_degenerate_quaternion_is_a_request_error(quaternion):
    from amr_kinematics.transforms import pose_matrix

    with pytest.raises(InvalidRequestError):
        pose_matrix([0.0, 0.0, 0.0], quaternion)
