"""Arms drawn from their own FK, from an IK service's parameters and joint states."""

import math
from pathlib import Path

import numpy as np
import pytest

from amr_kinematics.errors import ChainConfigError
from amr_kinematics.transforms import quaternion_matrix
from amr_util.parameter_file import dotted, node_parameters
from amr_viewer.arms import DRAWN_REACH, ArmSet, reach_of, rotation_wxyz

ROOT = Path(__file__).resolve().parents[2]
PARAMETERS = {"use_sim_time": False, **dotted(node_parameters(ROOT / "config" / "ik_chains.yaml", "ik_service"))}
RNG = np.random.default_rng(11)


@pytest.fixture(scope="module")
def arms():
    return ArmSet.from_parameters(PARAMETERS, origin=(5.0, 1.0, 0.0))


def test_every_shipped_chain_stands_in_its_cell_at_home(arms):
    assert list(arms.arms) == PARAMETERS["chains"]
    for index, arm in enumerate(arms.arms.values()):
        assert arm.origin == pytest.approx((5.0 + index, 1.0, 0.0))
        points = arm.points()
        expected = arm.origin + arm.scale * arm.config.chain.fk(arm.config.home).origins
        assert points == pytest.approx(expected)
        assert np.linalg.norm(points - points[0], axis=1).max() <= DRAWN_REACH + 1e-9, "scaled to the common reach"
    assert arms.bounds() == pytest.approx((4.5, 0.5, 5.5 + len(arms.arms) - 1, 1.5))


def test_joint_states_move_only_the_named_chain(arms):
    arm = arms.arms["rr2"]
    before = {name: other.version for name, other in arms.arms.items()}
    changed = arms.on_joint_state(
        ["rr2/q1", "rr2/q2", "nope/q1", "ur5/not_a_joint", "rr2/q3"], [0.5, -1.0, 3.0, 1.0, 2.0]
    )
    assert changed == {"rr2"} and arm.version == before["rr2"] + 1
    assert all(other.version == before[name] for name, other in arms.arms.items() if name != "rr2")
    assert arm.positions[:2] == pytest.approx([0.5, -1.0])
    tip = arm.points()[-1]
    a = arm.config.chain.a
    expected = arm.origin[:2] + arm.scale * np.array(
        [a[0] * math.cos(0.5) + a[1] * math.cos(-0.5), a[0] * math.sin(0.5) + a[1] * math.sin(-0.5)]
    )
    assert tip[:2] == pytest.approx(expected), "the planar 2R tip from its FK"
    assert arms.on_joint_state(["rr2/q1"], [0.5]) == set(), "the same value again changes nothing"
    assert arms.on_joint_state(["rr2/q1"], [math.nan]) == set()


def test_frames_are_the_fk_frames(arms):
    arm = arms.arms["ur5"]
    q = arm.config.chain.clamp(RNG.uniform(-2, 2, arm.config.chain.n))
    arms.on_joint_state([f"ur5/{joint}" for joint in arm.config.chain.joint_names], q)
    wxyz, positions = arm.frames()
    result = arm.config.chain.fk(q)
    assert positions[-1] == pytest.approx(arm.origin + arm.scale * result.tool[:3, 3])
    for quaternion, matrix in zip(wxyz, list(result.frames) + [result.tool], strict=True):
        w, x, y, z = quaternion
        assert quaternion_matrix((x, y, z, w)) == pytest.approx(matrix[:3, :3], abs=1e-9)


def test_rotation_quaternions_for_random_rotations():
    for _ in range(200):
        q = RNG.normal(size=4)
        q /= np.linalg.norm(q)
        matrix = quaternion_matrix(q)
        w, x, y, z = rotation_wxyz(matrix)
        assert w >= 0 and quaternion_matrix((x, y, z, w)) == pytest.approx(matrix, abs=1e-9)


def test_reach_covers_the_home_pose_and_is_seeded(arms):
    for arm in arms.arms.values():
        reach = reach_of(arm.config)
        home = arm.config.chain.fk(arm.config.home).origins
        assert reach >= np.linalg.norm(home - arm.config.chain.base[:3, 3], axis=1).max() - 1e-12
        assert reach == reach_of(arm.config)


def test_a_bad_chain_is_named():
    broken = {**PARAMETERS, "rr2.a": [0.1]}
    with pytest.raises(ChainConfigError, match="rr2"):
        ArmSet.from_parameters(broken)
