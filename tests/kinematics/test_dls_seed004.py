"""Damped least squares reproduces seed 004's table iteration by iteration.

The report's run: 6-row Jacobian (position rows in cm, rotation rows with zero
error), lambda^2 = 50 cm^2, q5 overwritten by q5 = -90 deg - q2 - q3 - q4 after each
step, converged when |e_xy| < 0.5 cm and |e_z| < 0.1 cm.  In SI units the same run
is links of 0.05 m, lambda^2 = 0.005 m^2 and rotation rows weighted 0.01 m/rad
(the centimetre per radian the report's mixed units imply).

Two misprints of the report's table are corrected here: row 1 prints q5 = -20.7625
(its own text computes -29.7625) and row 2 prints q1 = 28.5132 (17.1682 + 11.3460 =
28.5142); the positions printed in those rows match the corrected values.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.kinematics import seed004_arm

from amr_kinematics.solvers import get_solver

START = np.radians([0.0, 60.0, -40.0, -50.0, -60.0])
TARGET_CM = np.array([5.3, 4.78, 0.0])
# iteration: (theta deg, s cm, |e_xy| cm, |e_z| cm)
TABLE = [
    ([0.0, 60.0, -40.0, -50.0, -60.0], [11.5286, 0.0, 3.5402], 7.8514, 3.5402),
    ([17.1682, 57.7385, -52.0270, -65.9491, -29.7625], [9.6749, 2.9890, 0.3852], 4.7273, 0.3852),
    ([28.5142, 58.7780, -57.3891, -74.8012, -16.5877], [7.9239, 4.3048, -0.3949], 2.6665, 0.3949),
    ([35.0355, 60.6811, -59.9308, -80.4039, -10.3464], [6.8336, 4.7913, -0.4937], 1.5336, 0.4937),
    ([38.4883, 62.4710, -61.2281, -84.1672, -7.0757], [6.2037, 4.9326, -0.4196], 0.9165, 0.4196),
    ([40.2558, 63.8877, -61.9298, -86.7327, -5.2251], [5.8406, 4.9454, -0.3187], 0.5653, 0.3187),
    ([41.1485, 64.9328, -62.3211, -88.4750, -4.1367], [5.6279, 4.9179, -0.2301], 0.3557, 0.2301),
    ([41.5969, 65.6762, -62.5422, -89.6474, -3.4866], [5.5011, 4.8836, -0.1612], 0.2262, 0.1612),
    ([41.8217, 66.1929, -62.6678, -90.4289, -3.0962], [5.4244, 4.8537, -0.1107], 0.1446, 0.1107),
    ([41.9342, 66.5461, -62.7394, -90.9455, -2.8612], [5.3775, 4.8307, -0.0749], 0.0926, 0.0749),
]


def run(scale: float):
    """The report's run on the arm built with links of 5 * scale (0.01: metres, 1: cm)."""
    chain = seed004_arm(scale)
    return chain, get_solver("dls").solve(
        chain,
        TARGET_CM * scale,
        seed=START,
        damping=math.sqrt(50.0) * scale,
        adaptive_damping=0.0,
        angular_weight=1.0 * scale,
        coupling_update="project",
        restarts=False,
        axis_tolerance=(0.5 * scale, 0.5 * scale, 0.1 * scale),
        max_iterations=100,
        timeout=1.0,
        record_history=True,
    )


@pytest.mark.parametrize("scale", [0.01, 1.0], ids=["metres", "centimetres"])
def test_table_iteration_by_iteration(scale):
    chain, result = run(scale)
    assert result.success and result.iterations == 9
    assert len(result.history) == len(TABLE)
    for record, (theta, s, e_xy, e_z) in zip(result.history, TABLE, strict=True):
        np.testing.assert_allclose(np.degrees(record.q), theta, atol=1e-4, err_msg=f"iteration {record.iteration}")
        reached_cm = chain.fk(record.q).position / scale
        np.testing.assert_allclose(reached_cm, s, atol=1e-4)
        error = TARGET_CM - reached_cm
        assert math.hypot(error[0], error[1]) == pytest.approx(e_xy, abs=1e-4)
        assert abs(error[2]) == pytest.approx(e_z, abs=1e-4)


def test_final_errors_and_first_step():
    chain, result = run(0.01)
    e_cm = result.error * 100.0
    assert math.hypot(e_cm[0], e_cm[1]) == pytest.approx(0.0926, abs=5e-5)
    assert abs(e_cm[2]) == pytest.approx(0.0749, abs=5e-5)
    # the report's first step, joints 1-4 (joint 5 is then overwritten by the coupling)
    step = np.degrees(result.history[1].q - result.history[0].q)
    np.testing.assert_allclose(step[:4], [17.1682, -2.2615, -12.0270, -15.9491], atol=1e-4)


def test_shipped_config_reproduces_the_run(chain_set):
    result = chain_set["arm5"].solve([0.053, 0.0478, 0.0])
    assert result.success and result.iterations == 9
    np.testing.assert_allclose(np.degrees(result.q), TABLE[-1][0], atol=1e-4)
    assert math.hypot(*result.error[:2]) * 100 == pytest.approx(0.0926, abs=5e-5)


def test_reduced_coupling_update_converges_and_keeps_the_tool_down():
    chain = seed004_arm(0.01)
    result = get_solver("dls").solve(chain, TARGET_CM * 0.01, seed=START, tolerance=1e-6, timeout=1.0)
    assert result.success
    q = result.q
    assert q[4] == pytest.approx(-math.pi / 2 - q[1] - q[2] - q[3], abs=1e-12)
    np.testing.assert_allclose(chain.fk(q).tool[:3, 2], [math.sin(q[0]), -math.cos(q[0]), 0.0], atol=1e-9)
    np.testing.assert_allclose(chain.fk(q).tool[:3, 0], [0.0, 0.0, -1.0], atol=1e-9)  # link 5 points down
