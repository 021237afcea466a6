"""/solve_ik and /compute_fk in-process: the seeds and the industrial arms, bad input, caps, timeouts."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
import rclpy
import yaml
from rclpy.executors import MultiThreadedExecutor
from rclpy.parameter import Parameter
from support.ik_service import CONFIG, call, config_overrides, pose, quaternion_angle, solve_request, start, stop
from support.ros import spin_until

from amr_interfaces.srv import ComputeFK
from amr_kinematics.config import flatten_parameters

MAX_TIMEOUT = 1.0  # s, the node's cap in this module: an unbounded solve costs at most this
PARAMS = flatten_parameters(yaml.safe_load(CONFIG.read_text(encoding="utf-8")))
# seed 004: start (0, 60, -40, -50, -60) deg, the report's last row, |e_xy| and |e_z| in cm
SEED004_START = np.radians([0.0, 60.0, -40.0, -50.0, -60.0]).tolist()
SEED004_LAST = [41.9342, 66.5461, -62.7394, -90.9455, -2.8612]


@pytest.fixture(scope="module")
def served():
    """(executor, node, probe): the node active on the source config, 4 executor threads."""
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = MultiThreadedExecutor(num_threads=4, context=context)
    node, probe = start(context, executor, config_overrides() + [Parameter("max_timeout", value=MAX_TIMEOUT)])
    yield executor, node, probe
    stop(executor, (node, probe))
    executor.shutdown()
    context.try_shutdown()


def solve(served, chain, target, **fields):
    """The chain's own default timeouts are 5-50 ms: a solve that must succeed gets the module's cap
    instead, or a loaded CI machine (two test workers on two cores) descheduling it fails it."""
    executor, _, probe = served
    fields.setdefault("timeout", MAX_TIMEOUT)
    return call(executor, probe.solve, solve_request(chain, target, **fields))


def forward(served, chain, positions):
    executor, _, probe = served
    return call(executor, probe.fk, ComputeFK.Request(chain=chain, positions=list(positions)))


def quaternion(p) -> tuple[float, float, float, float]:
    return p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z


def test_seed004_reproduces_the_report(served):
    executor, _, probe = served
    probe.joint_states.clear()
    reply = solve(served, "arm5", pose(0.053, 0.0478, 0.0), seed=SEED004_START)
    assert reply.success, reply.message
    assert reply.iterations == 9 and reply.solver == "dls"
    reached = reply.reached.position
    error = np.array([0.053, 0.0478, 0.0]) - [reached.x, reached.y, reached.z]
    assert math.hypot(error[0], error[1]) == pytest.approx(0.000926, abs=5e-7)  # 0.0926 cm
    assert abs(error[2]) == pytest.approx(0.000749, abs=5e-7)  # 0.0749 cm
    np.testing.assert_allclose(np.degrees(reply.positions), SEED004_LAST, atol=1e-4)
    assert reply.joint_names == ["q1", "q2", "q3", "q4", "q5"]
    # every successful solve is published on ~/joint_states, names prefixed with the chain
    assert spin_until(executor, lambda: probe.joint_states, timeout=5.0)
    state = probe.joint_states[-1]
    assert state.name == ["arm5/q1", "arm5/q2", "arm5/q3", "arm5/q4", "arm5/q5"]
    assert list(state.position) == list(reply.positions)
    assert state.header.stamp.sec > 0


@pytest.mark.parametrize("target", [(0.1, 0.1), (-0.2, -0.2)])
def test_ull_five_joint_robot_converges_by_ccd(served, target):
    reply = solve(served, "ull5", pose(*target), seed=PARAMS["ull5.home"])
    assert reply.success, reply.message
    assert reply.solver == "ccd" and reply.iterations <= 10  # the report: 2 and 5
    assert reply.position_error <= 1e-4
    assert (reply.reached.position.x, reply.reached.position.y) == pytest.approx(target, abs=1e-4)


def test_ull_three_joint_robot_reports_the_closest_point(served):
    reply = solve(served, "ull3", pose(0.1, 0.1), seed=PARAMS["ull3.home"])
    assert not reply.success and "no convergence" in reply.message
    theta1, length2, theta3 = reply.positions
    assert theta1 == pytest.approx(0.4) and length2 == pytest.approx(0.02)
    assert theta3 == pytest.approx(0.716, abs=5e-4)
    assert reply.position_error == pytest.approx(0.0309524, abs=5e-7)  # 3.095 cm


def test_two_link_arm_by_its_closed_form(served):
    reply = solve(served, "rr2", pose(1.0, 1.0))
    assert reply.success and reply.solver == "analytic" and reply.iterations == 1
    q1, q2 = reply.positions
    tip = (2 * math.cos(q1) + 2 * math.cos(q1 + q2), 2 * math.sin(q1) + 2 * math.sin(q1 + q2))
    assert tip == pytest.approx((1.0, 1.0))


def random_configurations(chain: str, count: int, seed: int) -> list[list[float]]:
    rng = np.random.default_rng(seed)
    lower, upper = np.array(PARAMS[f"{chain}.lower"]), np.array(PARAMS[f"{chain}.upper"])
    return [rng.uniform(lower, upper).tolist() for _ in range(count)]


@pytest.mark.parametrize("chain", ["ur5", "panda"])
@pytest.mark.parametrize("with_orientation", [False, True], ids=["position", "pose"])
def test_industrial_arms_reach_fk_targets(served, chain, with_orientation):
    for q in random_configurations(chain, 5, seed=len(chain) + with_orientation):
        goal = forward(served, chain, q)
        assert goal.success, goal.message
        reply = solve(
            served,
            chain,
            goal.tool_pose,
            with_orientation=with_orientation,
            seed=PARAMS[f"{chain}.home"],
            timeout=MAX_TIMEOUT,
            max_iterations=100_000,
        )
        assert reply.success, reply.message
        assert reply.position_error <= 1e-5 and len(reply.positions) == len(q)
        reached = forward(served, chain, reply.positions).tool_pose  # the reply's pose is the FK of its positions
        assert [reached.position.x, reached.position.y, reached.position.z] == pytest.approx(
            [goal.tool_pose.position.x, goal.tool_pose.position.y, goal.tool_pose.position.z], abs=1e-5
        )
        if with_orientation:
            assert reply.orientation_error <= 1e-5
            assert quaternion_angle(quaternion(reached), quaternion(goal.tool_pose)) <= 1e-5


def test_empty_seed_starts_from_the_last_solution(served):
    target = pose(0.3, 0.2, 0.3)
    first = solve(served, "ur5", target, seed=PARAMS["ur5.home"])
    again = solve(served, "ur5", target)
    assert first.success and first.iterations > 0
    assert again.success and again.iterations == 0 and again.positions == first.positions


def test_unreachable_target_returns_the_closest_configuration(served):
    reply = solve(served, "ur5", pose(3.0, 0.0, 0.0))
    assert not reply.success and reply.message
    assert len(reply.positions) == 6 and all(-2 * math.pi <= q <= 2 * math.pi for q in reply.positions)
    assert 3.0 - 1.0 < reply.position_error < 3.0  # UR5 reaches ~0.95 m: the arm stretches towards the target
    fk = forward(served, "ur5", reply.positions).tool_pose
    assert (fk.position.x, fk.position.y, fk.position.z) == pytest.approx(
        (reply.reached.position.x, reply.reached.position.y, reply.reached.position.z)
    )


LONG = "x" * 10_000
BAD_REQUESTS = {
    "unknown chain": (dict(chain="nope"), "unknown chain 'nope'; known: arm5"),
    "huge chain name": (dict(chain=LONG), "unknown chain"),
    "short seed": (dict(seed=[0.0] * 3), "seed has 3 values; chain 'ur5' has 6 joints"),
    "absurd seed": (dict(seed=[0.0] * 100_000), "seed has 100000 values"),
    "NaN seed": (dict(seed=[0.0, math.nan, 0.0, 0.0, 0.0, 0.0]), "seed must be finite"),
    "NaN target": (dict(target=pose(math.nan, 0.2, 0.3)), "target must be finite"),
    "inf orientation": (dict(target=pose(0.3, 0.2, 0.3, (math.inf, 0.0, 0.0, 0.0))), "target must be finite"),
    "NaN tolerance": (dict(tolerance=math.nan), "tolerance must be a finite number >= 0"),
    "negative tolerance": (dict(tolerance=-1e-3), "tolerance must be a finite number >= 0"),
    "inf timeout": (dict(timeout=math.inf), "timeout must be a finite number >= 0"),
    "negative timeout": (dict(timeout=-1.0), "timeout must be a finite number >= 0"),
    "unknown solver": (dict(solver="bogus"), "unknown solver 'bogus'"),
    "huge solver name": (dict(solver=LONG), "unknown solver"),
    "analytic on a 6-DOF arm": (dict(solver="analytic"), "analytic solves planar 2R chains only"),
    "ccd on a spatial arm": (dict(solver="ccd"), "ccd works on planar chains"),
    "orientation of a 5-DOF arm": (
        dict(chain="arm5", seed=[], with_orientation=True),
        "cannot reach a full orientation",
    ),
    "orientation by ccd": (dict(chain="ull5", seed=[], with_orientation=True), "ccd places the tip only"),
    "orientation of a 2R arm": (dict(chain="rr2", seed=[], with_orientation=True), "cannot choose its orientation"),
    "non-unit quaternion": (
        dict(target=pose(0.3, 0.2, 0.3, (2.0, 0.0, 0.0, 0.0)), with_orientation=True),
        "must be a unit quaternion",
    ),
}


@pytest.mark.parametrize("fields, expected", BAD_REQUESTS.values(), ids=BAD_REQUESTS.keys())
def test_bad_requests_are_refused_with_a_reason(served, fields, expected):
    fields = {"chain": "ur5", "target": pose(0.3, 0.2, 0.3), **fields}
    reply = solve(served, fields.pop("chain"), fields.pop("target"), **fields)
    assert not reply.success
    assert expected in reply.message
    assert len(reply.message) <= 400 and len(reply.solver) <= 40
    assert len(reply.positions) in (0, len(reply.joint_names))


def test_absurd_limits_are_capped_and_the_timeout_holds(served):
    started = time.monotonic()
    reply = solve(served, "panda", pose(2.0, 2.0, 2.0), with_orientation=True, timeout=1e6, max_iterations=2**32 - 1)
    elapsed = time.monotonic() - started
    assert not reply.success
    assert f"timeout capped at {MAX_TIMEOUT} s" in reply.message and "max_iterations capped at 100000" in reply.message
    assert reply.message.startswith("timeout:"), "the capped timeout must end this solve (dls restarts until then)"
    assert MAX_TIMEOUT * 0.9 <= elapsed <= MAX_TIMEOUT + 5.0  # round trip included, slack for a loaded machine


@pytest.mark.parametrize("chain, solver", [("ur5", "dls"), ("panda", "pinv"), ("ull3", "ccd")])
def test_a_solve_never_runs_past_its_timeout(served, chain, solver):
    timeout = 0.02
    started = time.monotonic()
    reply = solve(
        served, chain, pose(2.0, 2.0, 2.0), solver=solver, timeout=timeout, max_iterations=100_000, tolerance=1e-12
    )
    assert not reply.success and reply.message and reply.iterations < 100_000
    assert time.monotonic() - started <= timeout + 5.0  # round trip included, slack for a loaded machine


def test_forward_kinematics_gives_tool_pose_and_joint_origins(served):
    reply = forward(served, "ur5", [0.0] * 6)
    assert reply.success and reply.message == "ok"
    tool = reply.tool_pose.position
    assert (tool.x, tool.y, tool.z) == pytest.approx((-0.81725, -0.19145, 0.089159 - 0.09465))
    assert len(reply.joint_origins) == 7  # the base, then each joint frame
    assert (reply.joint_origins[0].x, reply.joint_origins[0].y, reply.joint_origins[0].z) == (0.0, 0.0, 0.0)
    assert (reply.joint_origins[2].x, reply.joint_origins[2].z) == pytest.approx((-0.425, 0.089159))
    planar = forward(served, "rr2", [math.pi / 2, 0.0])
    assert (planar.tool_pose.position.x, planar.tool_pose.position.y) == pytest.approx((0.0, 4.0))


@pytest.mark.parametrize(
    "chain, positions, expected",
    [
        ("nope", [0.0], "unknown chain"),
        ("ur5", [0.0] * 5, "positions has 5 values; chain 'ur5' has 6 joints"),
        ("ur5", [0.0] * 100_000, "positions has 100000 values"),
        ("ur5", [0.0, 0.0, math.inf, 0.0, 0.0, 0.0], "must be finite"),
    ],
)
def test_forward_kinematics_refuses_bad_positions(served, chain, positions, expected):
    reply = forward(served, chain, positions)
    assert not reply.success and expected in reply.message


def test_forward_kinematics_notes_positions_outside_the_limits(served):
    reply = forward(served, "panda", [0.0] * 7)  # panda_joint4 must be <= -0.0698
    assert reply.success and "outside the joint limits: panda_joint4" in reply.message


def test_partial_pose_through_the_service(served):
    # UR5: position with the tool's z axis pointing straight down, roll free (5 of 6 constraints)
    fk = forward(served, "ur5", [0.4, -1.2, 1.0, -1.4, -1.57, 0.3])
    target = fk.tool_pose.position
    reply = solve(served, "ur5", pose(target.x, target.y, target.z), pointing=[0.0, 0.0, 1.0, 0.0, 0.0, -1.0])
    assert reply.success, reply.message
    assert reply.position_error <= 1e-5 and reply.orientation_error <= 1e-5
    w, x, y, z = quaternion(reply.reached)
    tool_z = (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y))  # R[:, 2]
    assert tool_z[2] == pytest.approx(-1.0, abs=1e-5)
    # x, y only: a z out of reach does not matter
    reply = solve(served, "ur5", pose(target.x, target.y, 5.0), task_weights=[1.0, 1.0, 0.0, 0.0, 0.0, 0.0])
    assert reply.success and abs(reply.reached.position.z - 5.0) > 1.0


@pytest.mark.parametrize(
    "fields, match",
    [
        ({"task_weights": [1.0, 1.0]}, "6 finite values"),
        ({"task_weights": [1.0, 1.0, 1.0, 0.0, 0.0, math.inf]}, "6 finite values"),
        ({"pointing": [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]}, "zero vector"),
        ({"task_weights": [1.0] * 6, "target": pose(0.3, 0.2, 0.4, (2.0, 0.0, 0.0, 0.0))}, "unit quaternion"),
    ],
)
def test_malformed_tasks_are_refused_by_name(served, fields, match):
    fields = dict(fields)
    reply = solve(served, "ur5", fields.pop("target", pose(0.3, 0.2, 0.4)), **fields)
    assert not reply.success and match in reply.message
