"""The wall-following controller on synthetic scans: PD, decisions, turns, time handling, bad data."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support.control import BIG, cast, corridor

from amr_control.wall_follower import Issue, WallFollower
from amr_util.scan import ScanData

DT = 0.05


class Drive:
    """Feeds a follower one scan per period with the odometry the test chooses."""

    def __init__(self, params: dict | None = None, t0: float = 0.0) -> None:
        self.follower = WallFollower(params or {})
        self.t = t0

    def step(self, scan: ScanData, v: float = 0.0, w: float = 0.0, dt: float = DT):
        command = self.follower.compute(scan, v, w, self.t)
        self.t += dt
        return command

    @property
    def state(self) -> str:
        return self.follower.state


FOLLOW_RIGHT = cast(corridor(left=1.0, right=0.2))
CLEAR = cast(corridor(left=0.2, right=0.2))
DEAD_END = cast(corridor(left=0.2, right=0.2, front=0.22))
RIGHT_OPEN = cast(corridor(left=0.2, right=0.2, front=0.22, right_to=-0.3))
LEFT_OPEN = cast(corridor(left=0.2, right=0.2, front=0.22, left_to=-0.3))
T_JUNCTION = cast(corridor(left=0.2, right=0.2, front=0.22, left_to=-0.3, right_to=-0.3))


# -- PD ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "wall, left, right, sign",
    [("right", 1.0, 0.3, -1.0), ("right", 1.0, 0.15, 1.0), ("left", 0.3, 1.0, 1.0), ("left", 0.15, 1.0, -1.0)],
)
def test_pd_turns_towards_a_far_wall_and_away_from_a_near_one(wall, left, right, sign):
    drive = Drive({"preferred_wall": wall})
    command = drive.step(cast(corridor(left=left, right=right)))
    assert drive.state == "FOLLOW"
    error = (right if wall == "right" else left) - 0.2
    assert command.w == pytest.approx(sign * 4.0 * abs(error))  # kp e, no derivative on the first sample
    assert command.v == 0.15 and command.ok


def test_pd_does_not_steer_towards_the_end_of_a_wall():
    # Just past the end of a thick wall on the right: the side window sees its top and its end
    # face (no straight line), and the nearest return is the corner, 5 cm beyond the target.
    def wall_end(depth):
        return [(-BIG, 1.0, BIG, 1.0), (-BIG, -depth, -0.015, -depth), (-0.015, -depth, -0.015, -1.0)]

    drive = Drive()
    drive.step(cast(corridor(left=1.0, right=0.25)))
    assert drive.step(cast(corridor(left=1.0, right=0.25))).w == pytest.approx(-0.2)  # a straight wall: kp e
    command = drive.step(cast(wall_end(0.25)))
    assert drive.state == "FOLLOW" and command.w == 0.0  # not swinging round the corner
    command = drive.step(cast(wall_end(0.15)))
    assert command.w > 0.0  # but away from a corner nearer than the target


def test_pd_output_saturates():
    drive = Drive({"kp": 10.0, "angular_limit": 0.34})
    assert drive.step(cast(corridor(left=1.0, right=0.35))).w == pytest.approx(-0.34)


NO_SKEW = {"wall_direction_window_deg": 1.0}
"""Direction windows too narrow for a fit: no skew, so the error rate is the difference of the fits."""


def test_along_a_straight_wall_the_error_rate_comes_from_the_skew():
    # A jump of the fitted distance between two scans of a parallel wall is noise: no rate.
    drive = Drive({"kp": 0.0, "kd": 1.0})
    drive.step(cast(corridor(left=1.0, right=0.20)))
    assert drive.step(cast(corridor(left=1.0, right=0.21))).w == pytest.approx(0.0, abs=1e-9)
    # A right wall running 10 deg counter-clockwise of the heading (the robot turned clockwise of
    # it, closing in at v sin 10 deg): de/dt = -v sin(skew), so w = kd v sin(skew), away from it.
    angle = math.radians(10.0)
    wall = [(-BIG, 1.0, BIG, 1.0), (-1.0, -0.2 - math.tan(angle), 1.0, -0.2 + math.tan(angle))]
    command = Drive({"kp": 0.0, "kd": 1.0}).step(cast(wall))
    assert command.w == pytest.approx(0.15 * math.sin(angle), rel=0.05)


@pytest.mark.parametrize("dt, filter_time, expected", [(0.05, 0.0, -0.2), (0.1, 0.0, -0.1), (0.05, 0.05, -0.1)])
def test_derivative_uses_the_real_time_between_stamps(dt, filter_time, expected):
    drive = Drive({"kp": 0.0, "kd": 1.0, "derivative_filter_time": filter_time, **NO_SKEW})
    drive.step(cast(corridor(left=1.0, right=0.20)), dt=dt)
    command = drive.step(cast(corridor(left=1.0, right=0.21)))
    assert command.w == pytest.approx(expected)  # de/dt = 0.01 m / dt, halved by the filter when tau = dt


def test_repeated_stamp_freezes_the_derivative():
    drive = Drive({"kp": 0.0, "kd": 1.0, **NO_SKEW})
    drive.step(cast(corridor(left=1.0, right=0.20)))
    drive.step(cast(corridor(left=1.0, right=0.21)), dt=0.0)
    command = drive.step(cast(corridor(left=1.0, right=0.25)))
    assert command.issues == (Issue.REPEATED_STAMP,)
    assert command.w == pytest.approx(-0.2)  # still the rate of the last real interval


def test_time_going_backwards_or_jumping_resets_the_derivative():
    drive = Drive({"kp": 0.0, "kd": 1.0, **NO_SKEW}, t0=10.0)
    drive.step(cast(corridor(left=1.0, right=0.20)))
    drive.t = 5.0
    command = drive.step(cast(corridor(left=1.0, right=0.21)))
    assert command.issues == (Issue.TIME_WENT_BACKWARDS,) and command.w == 0.0
    drive.t += 3.0
    command = drive.step(cast(corridor(left=1.0, right=0.25)))
    assert command.issues == (Issue.TIME_GAP,) and command.w == 0.0
    assert drive.step(cast(corridor(left=1.0, right=0.26))).ok


# -- decisions ----------------------------------------------------------------------------------------


def test_dead_end_turns_around():
    drive = Drive()
    command = drive.step(DEAD_END)
    assert drive.state == "TURN_AROUND"
    assert command.v == 0.0 and abs(command.w) == 0.5


@pytest.mark.parametrize(
    "scan, wall, expected",
    [
        (RIGHT_OPEN, "right", "TURN_RIGHT"),  # towards the followed side when it opens
        (LEFT_OPEN, "right", "TURN_LEFT"),  # else away from it
        (T_JUNCTION, "right", "TURN_RIGHT"),
        (T_JUNCTION, "left", "TURN_LEFT"),
        (RIGHT_OPEN, "left", "TURN_RIGHT"),
    ],
)
def test_front_blocked_turn_compares_the_sides(scan, wall, expected):
    drive = Drive({"preferred_wall": wall})
    drive.step(cast(corridor(left=0.2, right=0.2)))
    assert drive.state == "FOLLOW"
    command = drive.step(scan)
    assert drive.state == expected
    assert command.w == pytest.approx(0.5 if expected == "TURN_LEFT" else -0.5)


@pytest.mark.parametrize("wall, expected", [("right", "TURN_LEFT"), ("left", "TURN_RIGHT")])
def test_a_wall_met_while_searching_is_put_on_the_followed_side(wall, expected):
    drive = Drive({"preferred_wall": wall})
    drive.step(T_JUNCTION)  # no wall alongside yet: searching
    assert drive.state == expected


def test_random_junction_choices_are_reproducible():
    def choices():
        result = []
        for seed in range(20):
            drive = Drive({"preferred_wall": "random", "random_seed": seed})
            drive.step(CLEAR)
            drive.step(T_JUNCTION)
            result.append(drive.state)
        return result

    first = choices()
    assert first == choices()
    assert set(first) == {"TURN_LEFT", "TURN_RIGHT"}


def test_followed_wall_ending_leads_to_a_corner_turn():
    drive = Drive()
    drive.step(FOLLOW_RIGHT, v=0.15)
    assert drive.state == "FOLLOW"
    opening = cast(corridor(left=1.0, right=0.2, right_to=-0.3))
    steps = 0
    while drive.state != "TURN_RIGHT":
        command = drive.step(opening, v=0.15)
        steps += 1
        assert steps < 100
        if drive.state == "CORNER":
            assert (command.v, command.w) == (0.15, 0.0)
    # No wall fitted yet (the first scan only found it): the turn comes once the rotation centre is
    # target_wall_distance past the edge of the solid last seen passing the LiDAR on that side, the
    # right wall on the first scan (its returns up to WALL_END_SLACK ahead of the LiDAR), carried by
    # odometry (this static scan shows nothing newer): (0.2 - 0.032 + 0.03) m at 0.0075 m a period.
    assert steps == pytest.approx((0.2 - 0.032 + 0.03) / 0.0075, abs=1.0)


def test_a_corner_seen_early_is_approached_before_turning():
    drive = Drive({"front_threshold": 0.28, "turn_exit_distance": 0.5})
    command = drive.step(cast(corridor(left=0.2, right=0.2, front=0.27, right_to=-0.3)))
    assert drive.state == "APPROACH" and command.v == 0.1
    drive.step(cast(corridor(left=0.2, right=0.2, front=0.25, right_to=-0.3)), v=0.1)
    assert drive.state == "APPROACH"
    drive.step(cast(corridor(left=0.2, right=0.2, front=0.23, right_to=-0.3)), v=0.1)
    assert drive.state == "TURN_RIGHT"  # the rotation centre is now 0.2 m from the wall ahead


def test_an_oblique_obstacle_triggers_a_turn_away_then_resumes():
    drive = Drive()
    drive.step(FOLLOW_RIGHT)
    post = [(0.10, -0.09, 0.12, -0.07)]  # a short wall 3 cm ahead of the footprint, right of the centre line
    command = drive.step(cast(corridor(left=1.0, right=0.2) + post, beams=720))
    assert drive.state == "AVOID" and command.v == 0.0 and command.w > 0.0
    drive.step(FOLLOW_RIGHT)
    assert drive.state == "FOLLOW"


# -- turns --------------------------------------------------------------------------------------------


def test_turn_ends_on_the_odometry_angle_once_the_way_ahead_is_clear():
    drive = Drive()
    drive.step(LEFT_OPEN)
    assert drive.state == "TURN_LEFT"
    for _ in range(62):  # 62 * 0.05 s * 0.5 rad/s < pi / 2
        drive.step(CLEAR, w=0.5)
        assert drive.state == "TURN_LEFT"
    command = drive.step(CLEAR, w=0.5)
    assert drive.state == "STABILIZE" and command.v == 0.1


def test_turn_waits_for_a_clear_way_ahead():
    drive = Drive()
    drive.step(LEFT_OPEN)
    for _ in range(80):
        drive.step(DEAD_END, w=0.5)
    assert drive.state == "TURN_LEFT"
    drive.step(CLEAR, w=0.5)
    assert drive.state == "STABILIZE"


def test_turn_angle_is_corrected_by_the_skew_against_the_wall():
    # Rotated 10 deg counter-clockwise from the corridor: a left turn needs only 80 deg more.
    drive = Drive()
    drive.step(cast(corridor(left=0.2, right=0.2, front=0.22, left_to=-0.3), heading=math.radians(10.0)))
    assert drive.state == "TURN_LEFT"
    steps = 0
    while drive.state == "TURN_LEFT":
        drive.step(CLEAR, w=0.5)
        steps += 1
    assert steps == math.ceil(math.radians(80.0) / (0.5 * DT))


def test_turn_gives_up_after_its_timeout_when_odometry_shows_no_rotation():
    drive = Drive()
    drive.step(LEFT_OPEN)
    steps = 0
    while drive.state == "TURN_LEFT":
        drive.step(CLEAR, w=0.0)
        steps += 1
        assert steps < 1000
    assert steps * DT == pytest.approx(2.0 * (math.pi / 2) / 0.5, abs=DT)


def test_stabilization_lasts_its_time_then_follows():
    drive = Drive()
    drive.step(LEFT_OPEN)
    while drive.state == "TURN_LEFT":
        drive.step(CLEAR, w=0.5)
    states, speeds = [], []
    for _ in range(8):
        speeds.append(drive.step(CLEAR, v=0.1).v)
        states.append(drive.state)
    assert states[:6] == ["STABILIZE"] * 6 and states[-1] == "FOLLOW"  # 0.35 s after the turn ended
    assert speeds[:6] == [0.1] * 6 and speeds[-1] == 0.15


def test_reset_restores_the_start():
    drive = Drive({"preferred_wall": "random", "random_seed": 3})
    wall = drive.follower.followed_wall
    drive.step(T_JUNCTION)
    drive.follower.reset()
    assert drive.state == "SEARCH" and drive.follower.followed_wall == wall
    assert drive.step(cast(corridor(left=BIG, right=BIG))).v == 0.15  # searching straight ahead


def test_measurements_are_exposed_for_logs():
    drive = Drive()
    drive.step(cast(corridor(left=0.3, right=0.25, front=0.5)))
    m = drive.follower.measurements
    assert (m.front, m.left, m.right, m.followed_wall) == (
        pytest.approx(0.5),
        pytest.approx(0.3),
        pytest.approx(0.25),
        "right",
    )
    assert m.wall_distance == pytest.approx(0.25)
    assert m.clearance == pytest.approx(0.5 - 0.032 - (0.105 + 0.01), abs=1e-3)  # the disc widened by half the margin


# -- bad data -----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "scan, issue",
    [
        (ScanData([], 0.0, 0.1), Issue.BAD_SCAN),
        (ScanData([0.5] * 3, 0.0, 2 * math.pi / 3), Issue.BAD_SCAN),  # no beam inside the side window
        (ScanData([0.5] * 240, 1e308, 1e308), Issue.BAD_SCAN),
        (ScanData([0.5] * 240, 0.0, math.nan), Issue.BAD_SCAN),
        (ScanData([0.5] * 240, 0.0, 0.0), Issue.BAD_SCAN),
        (ScanData(["x"] * 240, 0.0, 0.01), Issue.BAD_SCAN),
        (ScanData([math.nan] * 240, 0.0, 2 * math.pi / 240), Issue.NO_VALID_BEAMS),
        (ScanData([1e30] * 240, 0.0, 2 * math.pi / 240, 0.12, 3.5), Issue.NO_VALID_BEAMS),
    ],
)
def test_unusable_scans_stop_the_robot_with_a_reason(scan, issue):
    drive = Drive()
    drive.step(FOLLOW_RIGHT)
    command = drive.step(scan)
    assert (command.v, command.w) == (0.0, 0.0)
    assert command.issues == (issue,)


def test_open_space_is_not_an_error():
    command = Drive().step(ScanData([math.inf] * 240, 0.0, 2 * math.pi / 240, 0.12, 3.5))
    assert command.ok and command.v == 0.15


@pytest.mark.parametrize("v, w", [(math.nan, 0.0), (0.0, math.inf), (50.0, 0.0), (0.0, -40.0), ("x", None)])
def test_bad_odometry_falls_back_to_the_last_command(v, w):
    drive = Drive()
    drive.step(LEFT_OPEN)  # turning left at 0.5 rad/s
    command = drive.step(CLEAR, v=v, w=w)
    assert command.issues == (Issue.BAD_ODOMETRY,)
    for _ in range(62):
        drive.step(CLEAR, v=v, w=w)
    assert drive.state == "STABILIZE"  # the turn progressed on the commanded rate: 63 periods


def test_non_finite_stamp_is_reported():
    follower = WallFollower()
    command = follower.compute(FOLLOW_RIGHT, 0.0, 0.0, math.nan)
    assert command.issues == (Issue.BAD_STAMP,) and math.isfinite(command.w)


floats = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 0.12, 1e308, -1e308, 1e-300]),
)


@settings(max_examples=300, deadline=None)
@given(
    ranges=st.lists(floats, max_size=400),
    angle_min=floats,
    increment=floats,
    limits=st.tuples(floats, floats),
    steps=st.lists(st.tuples(floats, floats, floats), min_size=1, max_size=4),
)
def test_garbage_never_raises_nor_yields_a_bad_command(ranges, angle_min, increment, limits, steps):
    follower = WallFollower({"angular_limit": 0.34})
    scan = ScanData(np.array(ranges, dtype=float), angle_min, increment, *limits)
    for stamp, v, w in steps:
        for current in (scan, FOLLOW_RIGHT):
            command = follower.compute(current, v, w, stamp)
            assert math.isfinite(command.v) and math.isfinite(command.w)
            assert 0.0 <= command.v <= 0.15
            assert abs(command.w) <= 0.5
