"""WorldControl, the simulator node's stepping without ROS: lockstep's held commands, pause / resume / step, the
pace, the resent observation, the /pose wait, realtime's command timeout, the stamps across a reset, and what a step
is judged to be (a collision, the goal)."""

from __future__ import annotations

import math
import sys

import pytest
import yaml
from support.simulation import TWO_IN_THE_PILLAR_ROOM, WORLDS, make_config

from amr_maps.world import load_world, world_from_dict
from amr_simulation.fleet import Fleet
from amr_simulation.simulator import Simulator
from amr_simulation.world_control import WorldControl

DT = 0.05


class Clock:
    """A wall clock the test moves."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class Log:
    """A logger that keeps (severity, line) and, as rclpy's does, refuses a second severity from one calling line
    ("Logger severity cannot be changed between calls")."""

    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []
        self._severities: dict[tuple, str] = {}

    def info(self, text: str) -> None:
        self._log("info", text)

    def warning(self, text: str) -> None:
        self._log("warning", text)

    def error(self, text: str) -> None:
        self._log("error", text)

    def _log(self, severity: str, text: str) -> None:
        caller = sys._getframe(2)
        site = (caller.f_code, caller.f_lineno)
        if self._severities.setdefault(site, severity) != severity:
            raise ValueError("Logger severity cannot be changed between calls.")
        self.lines.append((severity, text))

    def said(self, part: str) -> list[str]:
        return [line for _, line in self.lines if part in line]


class Harness:
    """A WorldControl with its publications recorded: (robot indices, the stamps' time, rate) per observation."""

    def __init__(self, sim, *, judge_poses=False, resend_period=1.0, pose_wait=0.0, scan_period=0.0, pace=0.0):
        self.clock, self.log, self.published = Clock(), Log(), []
        self.control = WorldControl(
            sim,
            publish=lambda turns, now, rate: self.published.append(([t.index for t in turns], now)),
            logger=lambda: self.log,
            judge_poses=judge_poses,
            clock=self.clock,
        )
        self.control.activate(resend_period=resend_period, pose_wait=pose_wait, scan_period=scan_period)
        self.period = self.control.pace(pace)
        self.control.observe(self.control.robots)

    @property
    def steps(self) -> int:
        return self.control.fleet.steps


def one_robot(**config) -> Simulator:
    return Simulator(load_world(WORLDS / "open_room.yaml"), make_config(dt=DT, **config))


def two_robots(**config) -> Fleet:
    return Fleet(world_from_dict(yaml.safe_load(TWO_IN_THE_PILLAR_ROOM)), make_config(dt=DT, **config))


def test_lockstep_steps_once_per_command_and_publishes_each_observation():
    h = Harness(one_robot())
    assert h.published == [([0], 0.0)], "activation publishes the first observation"
    for expected in (1, 2, 3):
        h.control.command(0, 0.2, 0.0)
        assert h.steps == expected
    assert [now for _, now in h.published] == pytest.approx([0.0, DT, 2 * DT, 3 * DT])
    assert h.control.robots[0].distance == pytest.approx(3 * DT * 0.2, rel=0.05)


def test_a_fleet_steps_when_every_robot_has_a_command():
    h = Harness(two_robots())
    h.control.command(0, 0.1, 0.0)
    h.control.command(0, 0.1, 0.0)
    assert h.steps == 0, "r2 has not answered: r1's commands are held"
    h.control.command(1, 0.1, 0.0)
    assert h.steps == 1 and len(h.control.robots[0].held) == 1
    h.control.command(1, 0.1, 0.0)
    assert h.steps == 2 and not h.control.robots[0].held
    assert h.published[-1][0] == [0, 1], "every robot's observation goes out after a step"


def test_a_non_finite_command_steps_at_zero_and_a_saturated_one_is_said():
    h = Harness(one_robot())
    h.control.command(0, math.nan, 0.0)
    assert h.steps == 1 and h.control.fleet.robots[0].twist == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
    assert h.log.said("refused a non-finite /cmd_vel")
    h.control.command(0, 5.0, 0.0)
    assert h.log.said("beyond the robot's limits: saturated to")
    h.control.command(0, math.nan, 0.0)
    assert len(h.log.said("refused a non-finite")) == 1, "throttled: once per WARNING_PERIOD"
    h.clock.now += 10.0
    h.control.command(0, math.nan, 0.0)
    assert len(h.log.said("refused a non-finite")) == 2


def test_pause_holds_resume_steps_the_held_command_and_step_owes_one():
    h = Harness(one_robot())
    h.control.command(0, 0.2, 0.0)
    assert h.control.pause().startswith("paused at t = 0.05 s (step 1)")
    assert h.control.pause().startswith("already paused")
    h.control.command(0, 0.2, 0.0)
    assert h.steps == 1, "paused: held"
    assert h.control.step_once().startswith("stepped to t = 0.10 s (step 2)")
    message = h.control.step_once()
    assert h.steps == 2 and message.startswith("1 step(s) owed at t = 0.10 s: taken on the next /cmd_vel"), message
    h.control.command(0, 0.2, 0.0)
    h.control.command(0, 0.2, 0.0)
    assert h.steps == 3, "the owed step, and no more"
    assert h.control.resume().startswith("running from t = 0.20 s (step 4)"), "resume steps the held command first"
    assert h.control.resume().startswith("already running")


def test_a_step_of_a_running_world_pauses_it_first():
    h = Harness(one_robot())
    assert h.control.step_once().startswith("paused; 1 step(s) owed")


def test_a_paused_step_is_taken_at_zero_for_the_robots_whose_command_does_not_come():
    h = Harness(two_robots(), resend_period=1.0)
    h.control.pause()
    h.control.command(0, 0.1, 0.0)
    h.clock.now += 2.0  # r2's driver holds it: no command comes
    assert h.control.step_once().startswith("stepped to t = 0.05 s (step 1)")
    assert not h.control.robots[0].held


def test_the_pace_releases_one_step_per_tick():
    h = Harness(one_robot(), pace=2.0)
    assert h.period == pytest.approx(DT / 2.0)
    h.control.command(0, 0.1, 0.0)
    h.control.command(0, 0.1, 0.0)
    assert h.steps == 0
    h.control.pace_tick()
    assert h.steps == 1
    h.control.pace_tick()
    assert h.steps == 2
    assert h.control.pace(0.0) is None and h.control.pace_ready, "pace 0: each command at once again"


def test_an_unanswered_observation_goes_out_again_after_the_resend_period():
    h = Harness(two_robots(), resend_period=1.0)
    h.control.command(0, 0.1, 0.0)
    h.control.resend_tick()
    assert len(h.published) == 1, "within the period: nothing resent"
    h.clock.now += 1.5
    h.control.resend_tick()
    assert h.published[-1] == ([1], 0.0), "only the silent robot's observation, the same stamp"
    assert h.log.said("step 0 waits for /r2/cmd_vel: publishing their observation again")
    h.control.pause()
    h.clock.now += 1.5
    h.control.resend_tick()
    assert len(h.published) == 2, "paused: nothing resent (/clock stops)"


def test_a_step_waits_for_the_pose_of_the_last_observation_at_most_pose_wait():
    h = Harness(one_robot(), judge_poses=True, pose_wait=2.0)
    turn = h.control.robots[0]
    assert turn.pose_due == 0
    h.control.command(0, 0.1, 0.0)
    assert h.steps == 0, "the /pose of the first observation has not come"
    h.control.pose(0, 0, *h.control.fleet.robots[0].pose, False)
    assert h.steps == 1 and turn.pose_due == round(DT * 1e9)
    h.control.command(0, 0.1, 0.0)
    h.control.release_late()
    assert h.steps == 1
    h.clock.now += 3.0
    h.control.release_late()
    assert h.steps == 2 and h.log.said("no /pose for the observation of step 1 within lockstep_pose_wait")


def test_an_observation_sent_again_whose_pose_came_is_not_waited_for_again():
    h = Harness(one_robot(), judge_poses=True, pose_wait=2.0)
    h.control.pose(0, 0, *h.control.fleet.robots[0].pose, False)
    h.clock.now += 1.5
    h.control.resend_tick()
    assert len(h.published) == 2 and h.control.robots[0].pose_due is None
    h.control.command(0, 0.1, 0.0)
    assert h.steps == 1


def test_a_pose_is_judged_against_the_truth_at_its_stamp():
    h = Harness(one_robot(), judge_poses=True)
    x, y, theta = h.control.fleet.robots[0].pose
    h.control.command(0, 0.2, 0.0)
    h.control.pose(0, 0, x + 0.03, y, theta, True)
    check = h.control.robots[0].check.state
    assert check.localized and check.position_error == pytest.approx(0.03)
    assert h.log.said("localized at t = 0.00 s, error 0.030 m")
    h.control.pose(0, 12345, x, y, theta, True)
    assert h.log.said("/pose not judged: no observation stamped")


def test_realtime_ticks_step_the_latest_command_until_it_times_out():
    h = Harness(one_robot(mode="realtime", command_timeout=0.1, rate=2.0))
    assert h.period == pytest.approx(DT / 2.0)
    h.control.command(0, 0.2, 0.0)
    assert h.steps == 0, "realtime: a command waits for the tick"
    for _ in range(3):
        h.control.tick()
    assert h.control.robots[0].command == (0.2, 0.0) and h.steps == 3
    h.control.tick()
    assert h.control.robots[0].command == (0.0, 0.0) and h.log.said("no /cmd_vel for 0.1 s: stopping")


def test_realtime_scans_every_scan_period():
    h = Harness(one_robot(mode="realtime"), scan_period=0.2)
    due = []
    for _ in range(8):
        h.control.tick()
        due.append(h.control.scan_due())
    assert due == [False, False, False, True, False, False, False, True]


def test_the_stamps_go_on_across_a_reset_and_a_teleport():
    h = Harness(one_robot())
    for _ in range(3):
        h.control.command(0, 0.2, 0.0)
    message = h.control.reset()
    assert message == "reset: robot at (-1.500, -1.000, 0.000)"
    assert h.control.fleet.time == 0.0 and h.published[-1][1] == pytest.approx(4 * DT)
    assert h.control.robots[0].distance == 0.0
    assert h.control.set_pose(0, 0.5, 0.5, 0.0).startswith("set_pose: robot at (0.500, 0.500")
    assert h.published[-1][1] == pytest.approx(5 * DT)


def test_a_collision_and_the_goal_are_said_once_each():
    h = Harness(one_robot())
    h.control.set_pose(0, 1.5 - 0.3, -1.25, 0.0)  # 0.3 m west of the goal's centre, facing it
    while not h.control.fleet.robots[0].goal_reached and h.steps < 100:
        h.control.command(0, 0.2, 0.0)
    lines = h.log.said("goal reached at")
    assert len(lines) == 1 and lines[0].endswith("0 collisions: stopping")
    h.control.set_pose(0, 1.75, 0.0, 0.0)  # facing the east wall, 0.25 m away
    for _ in range(60):
        h.control.command(0, 0.2, 0.0)
    collisions = h.log.said("collision 1 at")
    assert len(collisions) == 1 and "walls" not in collisions[0], "a one-robot world names no robots"


def test_a_fleet_robot_reset_alone_goes_on_one_dt_later():
    h = Harness(two_robots())
    h.control.command(0, 0.1, 0.0)
    h.control.command(1, 0.1, 0.0)
    assert h.control.reset_robot(1).startswith("reset: r2: robot at (1.600, -0.200")
    assert h.control.fleet.time == pytest.approx(DT) and h.published[-1] == ([1], pytest.approx(2 * DT))


def test_lines_of_every_severity_go_out_through_one_logger():
    h = Harness(two_robots(), judge_poses=True, resend_period=1.0)
    h.clock.now += 1.5
    h.control.resend_tick()  # info
    h.control.command(0, math.nan, 0.0)  # warning
    h.control.pose(0, 12345, 0.0, 0.0, 0.0, False)  # warning, not judged
    assert [severity for severity, _ in h.log.lines] == ["info", "warning", "warning"]
