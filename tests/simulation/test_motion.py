"""Driving: straight lines, spins, saturation, encoder odometry, goal and teleport."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.simulation import WORLDS, make_config

from amr_maps.world import load_world
from amr_simulation.errors import SimulationError
from amr_simulation.simulator import Simulator
from amr_util.geometry import wrap_angle


@pytest.fixture(scope="module")
def room():
    return load_world(WORLDS / "open_room.yaml")


def test_straight_10_s_at_0_15_ends_1_5_m_ahead(room) -> None:
    sim = Simulator(room, make_config())
    start = sim.pose
    for _ in range(200):  # 10 s at dt = 0.05 s
        sim.step(0.15, 0.0)
    assert math.isclose(sim.time, 10.0)
    assert math.hypot(sim.pose.x - start.x - 1.5, sim.pose.y - start.y) < 0.01
    assert sim.collisions == 0


def test_spin_of_two_pi_returns_to_the_start_heading(room) -> None:
    sim = Simulator(room, make_config())
    start = sim.pose
    steps = 126
    rate = 2.0 * math.pi / (steps * sim.config.dt)
    headings = []
    for _ in range(steps):
        sim.step(0.0, rate)
        headings.append(sim.pose.theta)
    assert abs(wrap_angle(sim.pose.theta - start.theta)) < 1e-9
    assert math.hypot(sim.pose.x - start.x, sim.pose.y - start.y) < 1e-9
    assert np.ptp(headings) > 6.0  # it did turn all the way round


def test_commands_saturate_keeping_curvature(room) -> None:
    sim = Simulator(room, make_config())
    sim.step(1.0, 1.0)  # curvature 1 /m, far beyond 0.22 m/s
    v, w = sim.odom_twist
    assert v <= 0.22 + 1e-12 and math.isclose(w / v, 1.0)
    vx, vy, wz = sim.twist
    assert math.isclose(vx, v) and abs(vy) < 1e-12 and math.isclose(wz, w)


def test_encoder_odometry_matches_ground_truth_without_noise(room) -> None:
    sim = Simulator(room, make_config())
    for k in range(400):
        sim.step(0.12, 0.6 * math.sin(0.02 * k))
        assert math.isclose(sim.odom_twist[0], sim.twist[0], abs_tol=1e-9)
    truth, odom = sim.pose, sim.odom_pose
    assert sim.collisions == 0
    assert math.hypot(truth.x - odom.x, truth.y - odom.y) < 1e-9
    assert abs(wrap_angle(truth.theta - odom.theta)) < 1e-9


def test_encoder_odometry_drifts_with_noise_and_slip(room) -> None:
    sim = Simulator(room, make_config(encoders={"noise": 0.05, "slip": 0.05}))
    for k in range(400):
        sim.step(0.12, 0.6 * math.sin(0.02 * k))
    truth, odom = sim.pose, sim.odom_pose
    assert math.hypot(truth.x - odom.x, truth.y - odom.y) > 0.01


def test_encoders_keep_counting_when_a_wall_holds_the_robot(room) -> None:
    sim = Simulator(room, make_config())
    sim.set_pose(1.8, -1.0, 0.0)  # 0.075 m from the east wall's face
    for _ in range(40):
        sim.step(0.2, 0.0)
    assert sim.pose.x < 1.975 - 0.105 + 0.002
    assert sim.odom_pose.x > 1.8 + 0.35  # 2 s at 0.2 m/s of wheel travel
    assert sim.encoder_increments[0] == pytest.approx(0.2 / 0.033 * sim.config.dt)
    assert abs(sim.twist[0]) < 1e-3


def test_goal_stops_the_robot_until_reset(room) -> None:
    sim = Simulator(room, make_config())
    sim.set_pose(1.0, -1.25, 0.0)  # goal: (1.5, -1.25), radius 0.2
    while not sim.goal_reached:
        sim.step(0.2, 0.0)
        assert sim.time < 5.0
    x = sim.pose.x
    for _ in range(20):
        sim.step(0.2, 0.5)
    assert sim.pose.x == x and sim.wheel_speeds == (0.0, 0.0)
    sim.reset()
    assert not sim.goal_reached and sim.time == 0.0 and sim.pose == room.start


def test_without_stop_at_goal_the_goal_is_only_judged(room) -> None:
    sim = Simulator(room, make_config(stop_at_goal=False))
    sim.set_pose(1.0, -1.25, 0.0)
    while not sim.goal_reached:
        sim.step(0.2, 0.0)
    x = sim.pose.x
    for _ in range(10):
        sim.step(0.2, 0.0)
    assert sim.pose.x == pytest.approx(x + 10 * 0.2 * sim.config.dt, abs=1e-3) and sim.goal_reached


def test_set_pose_teleports_and_restarts_odometry(room) -> None:
    sim = Simulator(room, make_config())
    sim.step(0.2, 0.3)
    sim.set_pose(0.5, -1.0, 1.0)
    assert sim.pose == sim.odom_pose == (0.5, -1.0, 1.0)
    assert sim.twist == (0.0, 0.0, 0.0)
    assert np.isnan(sim.trajectory[-2]).all()  # the drawn path breaks at the jump


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (1.95, 0.0, 0.0), (float("nan"), 0.0, 0.0)])
def test_set_pose_refuses_walls_and_nan(room, pose) -> None:
    sim = Simulator(room, make_config())
    with pytest.raises(SimulationError, match="set_pose"):
        sim.set_pose(*pose)
    assert sim.pose == room.start


def test_start_inside_a_wall_is_refused(room) -> None:
    with pytest.raises(SimulationError, match="overlaps a wall"):
        Simulator(room, make_config(start=(0.0, 0.05, 0.0)))


@pytest.mark.parametrize("command", [(float("nan"), 0.0), (0.1, float("inf"))])
def test_non_finite_commands_are_refused(room, command) -> None:
    sim = Simulator(room, make_config())
    with pytest.raises(SimulationError, match="finite"):
        sim.step(*command)
    assert sim.steps == 0


def test_same_seed_same_commands_same_observations(room) -> None:
    config = make_config(lidar={"noise_std": 0.01}, encoders={"noise": 0.02, "slip": 0.02}, seed=7)

    def run(sim: Simulator) -> list:
        out = []
        for k in range(60):
            sim.step(0.15, 0.4 * math.cos(0.1 * k))
            out.append((sim.pose, sim.odom_pose, sim.encoder_increments, np.array(sim.ranges)))
        return out

    first, second = run(Simulator(room, config)), run(Simulator(room, config))
    for a, b in zip(first, second, strict=True):
        assert a[:3] == b[:3] and np.array_equal(a[3], b[3])
    sim = Simulator(room, config)
    run(sim)
    sim.reset()  # reset reseeds: the run repeats
    again = run(sim)
    assert all(np.array_equal(a[3], b[3]) for a, b in zip(first, again, strict=True))
    other = run(Simulator(room, make_config(lidar={"noise_std": 0.01}, encoders={"noise": 0.02}, seed=8)))
    assert not np.array_equal(first[-1][3], other[-1][3])
