"""URDF chains: parsing, FK equal to the DH tables, solving with real link frames."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from support.kinematics import random_targets

from amr_kinematics.chain import Chain
from amr_kinematics.config import load_chain_set
from amr_kinematics.errors import ChainConfigError
from amr_kinematics.solvers import get_solver
from amr_kinematics.transforms import matrix_rpy, rot_z
from amr_kinematics.urdf import urdf_chain

URDF_DIR = Path(__file__).resolve().parents[2] / "config" / "urdf"


def _origin(frame: np.ndarray) -> str:
    values = [*frame[:3, 3].tolist(), *matrix_rpy(frame[:3, :3])]
    return '<origin xyz="{!r} {!r} {!r}" rpy="{!r} {!r} {!r}"/>'.format(*map(float, values))


def _ry(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s, 0.0], [0.0, 1.0, 0.0, 0.0], [-s, 0.0, c, 0.0], [0.0, 0.0, 0.0, 1.0]])


def urdf_from_dh(chain: Chain, axis: str) -> str:
    """A URDF of a DH chain: its segments F_0 M_1 ... M_n F_n as joint origins, each origin
    split by an extra fixed joint (folding must undo it).  ``axis``: "z" as is; "-z" (the
    joint values change sign); "x" with every joint frame turned by Ry(-pi/2), which takes
    x onto z, and turned back in the next origin (the same motion, described otherwise)."""
    fixed, motions = chain.segments()
    turn = _ry(-math.pi / 2) if axis == "x" else np.eye(4)
    links, joints, parent = ['<link name="base"/>'], [], "base"
    for i, motion in enumerate(motions):
        frame = (np.linalg.inv(turn) if i else np.eye(4)) @ fixed[i] @ turn
        half = np.eye(4)
        half[:3, 3] = frame[:3, 3] / 2.0
        links += [f'<link name="mid{i}"/>', f'<link name="link{i}"/>']
        joints.append(
            f'<joint name="fix{i}" type="fixed"><parent link="{parent}"/><child link="mid{i}"/>{_origin(half)}</joint>'
        )
        kind = "prismatic" if motion != "rz" else "revolute"
        vector = {"z": "0 0 1", "-z": "0 0 -1", "x": "1 0 0"}[axis]
        low, high = (-chain.upper[i], -chain.lower[i]) if axis == "-z" else (chain.lower[i], chain.upper[i])
        joints.append(
            f'<joint name="{chain.joint_names[i]}" type="{kind}"><parent link="mid{i}"/>'
            f'<child link="link{i}"/>{_origin(np.linalg.inv(half) @ frame)}<axis xyz="{vector}"/>'
            f'<limit lower="{float(low)!r}" upper="{float(high)!r}"/></joint>'
        )
        parent = f"link{i}"
    links.append('<link name="tip"/>')
    joints.append(
        f'<joint name="tool" type="fixed"><parent link="{parent}"/><child link="tip"/>'
        f"{_origin(np.linalg.inv(turn) @ fixed[-1])}</joint>"
    )
    return f'<robot name="{chain.name}">' + "".join(links + joints) + "</robot>"


@pytest.mark.parametrize("axis", ["z", "-z", "x"])
def test_a_urdf_written_from_each_dh_chain_has_the_same_fk(chain_set, axis):
    rng = np.random.default_rng(1)
    sign = -1.0 if axis == "-z" else 1.0  # about -z, the same motion needs the opposite value
    for name, config in chain_set.items():
        dh = config.chain
        if any(m == "tx" for m in dh.segments()[1]):
            continue  # planar prismatic joints slide along x: no DH table to compare with in z form
        urdf = urdf_chain(name, urdf_from_dh(dh, axis), "base", "tip")
        assert urdf.joint_names == dh.joint_names and np.array_equal(urdf.prismatic, dh.prismatic)
        for _ in range(20):
            q = rng.uniform(dh.lower, dh.upper)
            np.testing.assert_allclose(urdf.fk(sign * q).tool, dh.fk(q).tool, atol=1e-12, rtol=0)
            kernel = urdf.kernel.pose_jacobian((sign * q).tolist())
            np.testing.assert_allclose(kernel[:3], dh.fk(q).position, atol=1e-12, rtol=0)
            jac = np.array(kernel[12]).reshape(6, -1)
            np.testing.assert_allclose(jac, sign * dh.jacobian(q), atol=1e-12, rtol=0)


def test_ur5_real_link_frames_are_the_dh_pose_turned_by_pi(chain_set):
    # ur_description's base_link faces the other way from the DH base frame; tool0 is the DH tool frame
    urdf = urdf_chain("ur5", str(URDF_DIR / "ur5.urdf"), "base_link", "tool0")
    dh = chain_set["ur5"].chain
    for q in np.random.default_rng(2).uniform(-3.0, 3.0, (20, 6)):
        np.testing.assert_allclose(urdf.fk(q).tool, rot_z(math.pi) @ dh.fk(q).tool, atol=1e-9)  # URDF rounds pi/2


@pytest.mark.parametrize(
    "tip, tool", [("panda_link8", None), ("panda_hand_tcp", [0.0, 0.0, 0.2104, 0.0, 0.0, -math.pi / 4])]
)
def test_panda_urdf_matches_its_dh_table(chain_set, tip, tool):
    from amr_kinematics.transforms import xyz_rpy_matrix

    urdf = urdf_chain("panda", str(URDF_DIR / "panda.urdf"), "panda_link0", tip)
    dh = chain_set["panda"].chain
    flange_to_tcp = np.eye(4) if tool is None else np.linalg.inv(dh.tool) @ xyz_rpy_matrix(tool)
    np.testing.assert_array_equal(urdf.lower, dh.lower)
    for q in np.random.default_rng(3).uniform(dh.lower, dh.upper, (20, 7)):
        np.testing.assert_allclose(urdf.fk(q).tool, dh.fk(q).tool @ flange_to_tcp, atol=1e-12)


@pytest.mark.parametrize(
    "file, base, tip, dh_name",
    [("ur5.urdf", "base_link", "tool0", "ur5"), ("panda.urdf", "panda_link0", "panda_link8", "panda")],
)
def test_urdf_arms_solve_as_well_as_their_dh_versions(chain_set, file, base, tip, dh_name):
    urdf = urdf_chain(dh_name, str(URDF_DIR / file), base, tip)
    dh_config = chain_set[dh_name]
    for with_orientation in (False, True):
        for target in random_targets(urdf, 25, seed=4):
            goal = target if with_orientation else target[:3, 3]
            result = get_solver("dls").solve(
                urdf, goal, seed=dh_config.home, with_orientation=with_orientation, timeout=0.05
            )
            assert result.success, result.message


def test_chain_loader_takes_a_urdf_by_path_package_or_inline_xml(tmp_path):
    xml = (URDF_DIR / "panda.urdf").read_text()
    for source in (str(URDF_DIR / "panda.urdf"), "package://amr_kinematics/config/urdf/panda.urdf", xml):
        configs = load_chain_set(
            {
                "chains": ["arm"],
                "arm": {
                    "urdf": source,
                    "base_link": "panda_link0",
                    "tip_link": "panda_hand_tcp",
                    "solver": "dls",
                    "home": [
                        0.0,
                        -0.7853981633974483,
                        0.0,
                        -2.356194490192345,
                        0.0,
                        1.5707963267948966,
                        0.7853981633974483,
                    ],
                },
            }
        )
        chain = configs["arm"].chain
        assert chain.n == 7 and chain.joint_names[0] == "panda_joint1"
        target = chain.fk(configs["arm"].home + 0.1).tool
        assert configs["arm"].solve(target, with_orientation=True, timeout=0.05).success


def test_continuous_fixed_and_mimic_joints():
    xml = """<robot name="r"><link name="b"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="t"/>
      <joint name="spin" type="continuous"><parent link="b"/><child link="l1"/><axis xyz="0 0 1"/></joint>
      <joint name="lift" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.2" rpy="0 0 0"/>
        <axis xyz="0 1 0"/><limit lower="-1.0" upper="1.0"/></joint>
      <joint name="follow" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0.3 0 0"/>
        <axis xyz="0 1 0"/><limit lower="-2.0" upper="2.0"/><mimic joint="lift" multiplier="-2.0" offset="0.1"/></joint>
      <joint name="end" type="fixed"><parent link="l3"/><child link="t"/><origin xyz="0.1 0 0"/></joint></robot>"""
    chain = urdf_chain("r", xml, "b", "t")
    assert chain.joint_names == ("spin", "lift", "follow") and chain.free.tolist() == [0, 1]
    assert chain.lower[0] == -math.pi and chain.upper[0] == math.pi  # wrapped across: no angle out of reach
    q = chain.apply_coupling([0.0, 0.5, 0.0])
    assert q[2] == pytest.approx(-2.0 * 0.5 + 0.1)
    # lift 0.5 about y then follow -0.9: the last link's direction is pitch 0.5 - 0.9
    tip = chain.fk(q).position
    expected = np.array([0.3 * math.cos(0.5), 0.0, 0.2 - 0.3 * math.sin(0.5)]) + 0.1 * np.array(
        [math.cos(-0.4), 0.0, -math.sin(-0.4)]
    )
    np.testing.assert_allclose(tip, expected, atol=1e-12)


@pytest.mark.parametrize(
    "xml, base, tip, key, match",
    [
        ("<robot", "b", "t", "arm.urdf", "not valid XML"),
        ("<model/>", "b", "t", "arm.urdf", "expected <robot>"),
        ('<robot name="r"><link name="b"/></robot>', "b", "t", "arm.tip_link", "'t' is not in the URDF"),
        ('<robot name="r"><link name="b"/><link name="t"/></robot>', "b", "t", "arm.base_link", "not an ancestor"),
        (
            '<robot name="r"><link name="b"/><link name="t"/><joint name="j" type="fixed"><parent link="b"/>'
            '<child link="t"/></joint></robot>',
            "b",
            "t",
            "arm.urdf",
            "at least one joint",
        ),
        (
            '<robot name="r"><link name="b"/><link name="t"/><joint name="j" type="floating"><parent link="b"/>'
            '<child link="t"/></joint></robot>',
            "b",
            "t",
            "arm.urdf",
            "'floating'",
        ),
        (
            '<robot name="r"><link name="b"/><link name="t"/><joint name="j" type="revolute"><parent link="b"/>'
            '<child link="t"/></joint></robot>',
            "b",
            "t",
            "arm.urdf",
            "needs <limit",
        ),
        (
            '<robot name="r"><link name="b"/><link name="t"/><joint name="j" type="revolute"><parent link="b"/>'
            '<child link="t"/><origin xyz="0 nan"/><limit lower="0" upper="1"/></joint></robot>',
            "b",
            "t",
            "arm.urdf",
            "3 finite numbers",
        ),
        ("/nonexistent/arm.urdf", "b", "t", "arm.urdf", "cannot read URDF"),
        ("package://amr_kinematics/config/urdf/nothing.urdf", "b", "t", "arm.urdf", "cannot read URDF"),
    ],
)
def test_malformed_urdf_chains_are_refused_by_name(xml, base, tip, key, match):
    with pytest.raises(ChainConfigError) as info:
        load_chain_set({"chains": ["arm"], "arm": {"urdf": xml, "base_link": base, "tip_link": tip}})
    assert info.value.key == key and match in str(info.value)


def test_dh_keys_beside_a_urdf_are_refused():
    with pytest.raises(ChainConfigError, match="comes from the URDF"):
        load_chain_set(
            {
                "chains": ["arm"],
                "arm": {
                    "urdf": str(URDF_DIR / "ur5.urdf"),
                    "base_link": "base_link",
                    "tip_link": "tool0",
                    "theta": [0.0] * 6,
                },
            }
        )
