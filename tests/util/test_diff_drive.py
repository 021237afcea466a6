"""Differential-drive kinematics (seed 002 sections 1-2) and curvature-keeping saturation."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from amr_util.diff_drive import DiffDrive, DiffDriveError

# TurtleBot3 Burger figures (ROBOTIS e-Manual), as config/simulator.yaml gives them to the simulator
TURTLEBOT3_BURGER = DiffDrive(
    wheel_radius=0.033, track=0.160, max_wheel_speed=0.22 / 0.033, max_linear=0.22, max_angular=2.84
)

speeds = st.floats(-5.0, 5.0, allow_nan=False)


def test_wheel_speeds_match_the_seed_equations():
    # seed 002 (3)-(4): phi_l = (v - b w) / r, phi_r = (v + b w) / r, b = track / 2
    drive = DiffDrive(wheel_radius=0.033, track=0.160)
    left, right = drive.wheel_speeds(0.2, 1.0)
    assert left == pytest.approx((0.2 - 0.08 * 1.0) / 0.033)
    assert right == pytest.approx((0.2 + 0.08 * 1.0) / 0.033)


def test_body_twist_matches_the_seed_equations():
    # seed 002 (7)-(8): v = r (phi_l + phi_r) / 2, w = r (phi_r - phi_l) / (2 b)
    drive = DiffDrive(wheel_radius=0.033, track=0.160)
    v, w = drive.body_twist(3.0, 5.0)
    assert v == pytest.approx(0.033 * 8.0 / 2.0)
    assert w == pytest.approx(0.033 * 2.0 / 0.160)


@given(speeds, speeds)
@settings(max_examples=50)
def test_inverse_then_forward_is_identity(v, w):
    drive = DiffDrive(wheel_radius=0.05, track=0.3)
    back = drive.body_twist(*drive.wheel_speeds(v, w))
    assert back == pytest.approx((v, w), abs=1e-9)


@given(speeds, speeds)
@settings(max_examples=50)
def test_saturation_keeps_curvature_and_limits(v, w):
    drive = TURTLEBOT3_BURGER
    sv, sw = drive.saturate(v, w)
    left, right = drive.command(v, w)
    assert max(abs(left), abs(right)) <= drive.max_wheel_speed * (1 + 1e-9)
    assert abs(sv) <= drive.max_linear * (1 + 1e-9) and abs(sw) <= drive.max_angular * (1 + 1e-9)
    # same direction and same curvature w / v: the command is only scaled down
    assert sv * w == pytest.approx(sw * v, abs=1e-9)
    assert sv * v >= 0 and sw * w >= 0


def test_saturation_scales_both_wheels_by_one_factor():
    drive = DiffDrive(wheel_radius=0.1, track=0.5, max_wheel_speed=10.0)
    left, right = drive.wheel_speeds(2.0, 4.0)  # right wheel 30 rad/s: three times too fast
    sat_left, sat_right = drive.command(2.0, 4.0)
    assert sat_right == pytest.approx(10.0)
    assert sat_left / sat_right == pytest.approx(left / right)


def test_command_within_limits_is_unchanged():
    assert TURTLEBOT3_BURGER.saturation_scale(0.1, 0.5) == 1.0
    assert TURTLEBOT3_BURGER.command(0.1, 0.5) == TURTLEBOT3_BURGER.wheel_speeds(0.1, 0.5)


@pytest.mark.parametrize("field", ["wheel_radius", "track", "max_wheel_speed", "max_linear", "max_angular"])
@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, True, "1"])
def test_bad_parameters_are_refused(field, bad):
    with pytest.raises(DiffDriveError, match=field):
        DiffDrive(**{field: bad})


def test_infinite_geometry_is_refused():
    with pytest.raises(DiffDriveError):
        DiffDrive(track=math.inf)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_speeds_are_refused(bad):
    with pytest.raises(DiffDriveError):
        TURTLEBOT3_BURGER.command(bad, 0.0)
    with pytest.raises(DiffDriveError):
        TURTLEBOT3_BURGER.body_twist(0.0, bad)


@pytest.mark.parametrize(
    "linear, angular, expected",
    [
        (1e308, 0.0, (0.22, 0.0)),
        (-1e308, 0.0, (-0.22, 0.0)),
        (0.0, 1e308, (0.0, 0.22 / 0.08)),
        (-5.0, 0.0, (-0.22, 0.0)),  # spinning: the wheels limit it
    ],
)
def test_absurd_but_finite_twists_saturate_like_any_other(linear, angular, expected):
    drive = DiffDrive(wheel_radius=0.033, track=0.16, max_wheel_speed=0.22 / 0.033, max_linear=0.22, max_angular=2.84)
    v, w = drive.saturate(linear, angular)
    assert (v, w) == pytest.approx(expected)
