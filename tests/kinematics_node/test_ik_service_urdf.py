"""A URDF chain served by the node: /compute_fk and /solve_ik answer for it."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml
from support.ik_service import CONFIG, call, config_overrides, pose, solve_request

from amr_interfaces.srv import ComputeFK
from amr_kinematics.config import flatten_parameters, load_chain_set

UR5_URDF = Path(__file__).resolve().parents[2] / "config" / "urdf" / "ur5.urdf"


def test_compute_fk_and_solve_ik_for_a_urdf_chain(launch, multi_executor):
    shipped = flatten_parameters(yaml.safe_load(CONFIG.read_text(encoding="utf-8")))["chains"]
    overrides = config_overrides(
        **{
            "chains": shipped + ["ur5_urdf"],
            "ur5_urdf.urdf": UR5_URDF.read_text(encoding="utf-8"),  # the XML itself, as robot_description holds it
            "ur5_urdf.base_link": "base_link",
            "ur5_urdf.tip_link": "tool0",
        }
    )
    _, probe = launch(overrides)
    q = [0.4, -1.2, 1.0, -1.4, -1.57, 0.3]
    reply = call(multi_executor, probe.fk, ComputeFK.Request(chain="ur5_urdf", positions=q))
    assert reply.success, reply.message
    assert list(reply.joint_names) == [
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ]
    dh = load_chain_set(yaml.safe_load(CONFIG.read_text(encoding="utf-8")))["ur5"].chain
    expected = dh.fk(q).position * [-1.0, -1.0, 1.0]  # base_link faces the other way from the DH base
    p = reply.tool_pose.position
    np.testing.assert_allclose([p.x, p.y, p.z], expected, atol=1e-9)
    solved = call(
        multi_executor,
        probe.solve,
        solve_request(
            "ur5_urdf",
            pose(
                p.x,
                p.y,
                p.z,
                (
                    reply.tool_pose.orientation.w,
                    reply.tool_pose.orientation.x,
                    reply.tool_pose.orientation.y,
                    reply.tool_pose.orientation.z,
                ),
            ),
            with_orientation=True,
            timeout=0.1,
        ),
    )
    assert solved.success and solved.position_error <= 1e-5 and solved.orientation_error <= 1e-5
    assert math.isfinite(solved.reached.position.x)
