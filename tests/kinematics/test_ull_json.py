"""Import of the ULL report's JSON joint lists (seed 000, figures 3.4 and 3.5)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from support.ull_figures import FIGURE_3_4, FIGURE_3_5

from amr_kinematics.errors import ChainConfigError
from amr_kinematics.ull_json import load_ull_json


def test_nested_lists_flatten_in_order(tmp_path):
    path = tmp_path / "robot.json"
    path.write_text(json.dumps(FIGURE_3_5))
    chain, q0 = load_ull_json(path, name="ull5")
    assert chain.types == ("revolute", "prismatic", "revolute", "revolute", "prismatic")
    np.testing.assert_array_equal(chain.lower, [-5, 0, -5, -5, 0])
    np.testing.assert_array_equal(chain.upper, [5, 1000, 5, 5, 1000])
    np.testing.assert_array_equal(q0, [0, 5, 0, 0, 5])  # prismatic value = its length a
    np.testing.assert_allclose(chain.fk(q0).position, [25.0, 0.0, 0.0])


def test_length_scale_reads_centimetres(chain_set):
    chain, q0 = load_ull_json(json.dumps(FIGURE_3_4), name="ull3", length_scale=0.01)
    shipped = chain_set["ull3"].chain
    np.testing.assert_allclose(chain.a, shipped.a)
    np.testing.assert_allclose(chain.upper, shipped.upper)
    np.testing.assert_allclose(q0, [0.0, 0.05, 0.0])  # outside [0, 0.02]: solvers clamp it


def test_same_robot_as_the_shipped_yaml(chain_set):
    chain, _ = load_ull_json(FIGURE_3_5, length_scale=0.01)
    shipped = chain_set["ull5"].chain
    q = np.array([0.3, 0.04, -0.5, 1.0, 0.02])
    np.testing.assert_allclose(chain.fk(q).tool, shipped.fk(q).tool, atol=1e-12)


@pytest.mark.parametrize(
    "mutate, key",
    [
        (lambda j: j[1].update(type="esferica"), "joint 2.type"),
        (lambda j: j[2].pop("limit_sup"), "joint 3.limit_sup"),
        (lambda j: j[0].update(a="5"), "joint 1.a"),
        (lambda j: j[0].update(th=float("nan")), "joint 1.th"),
    ],
)
def test_malformed_joint_names_the_joint(mutate, key):
    joints = [dict(j) for j in FIGURE_3_4]
    mutate(joints)
    with pytest.raises(ChainConfigError) as info:
        load_ull_json(joints)
    assert info.value.key == key


def test_limits_out_of_order_are_refused():
    joints = [dict(j) for j in FIGURE_3_4]
    joints[0].update(limit_inf=1.0, limit_sup=0.0)
    with pytest.raises(ChainConfigError, match="lower"):
        load_ull_json(joints)


def test_not_json():
    with pytest.raises(ChainConfigError, match="not valid JSON"):
        load_ull_json("[{oops")
