"""The lockstep harness (amr_util.harness): what it observes, the order it steps parts in, when it stops."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from amr_util.harness import Harness, OneRobot, Robots, drive, localize, stand


class Sim:
    """A one-robot simulator's observation interface; the robot moves x by v * dt per step, logging calls."""

    def __init__(self, log: list) -> None:
        self.time, self.x, self.log = 0.0, 0.0, log
        self.lidar = SimpleNamespace(angle_min=-1.0, angle_increment=0.5, range_min=0.1, range_max=3.5)

    @property
    def ranges(self):
        return np.array([1.0, 2.0, math.inf, 3.0, 0.5]) + self.x

    @property
    def odom_pose(self):
        return (self.x, 0.0, 0.0)

    @property
    def odom_twist(self):
        return (0.1, 0.0)

    def step(self, v: float, w: float) -> None:
        self.log.append(("step", v, w))
        self.x += v * 0.05
        self.time += 0.05


def test_each_period_is_before_then_observe_then_the_parts_in_order_then_one_step():
    log: list = []
    sim = Sim(log)

    def first(frame):
        log.append(("first", frame.observation.stamp, frame.observation.odometry))
        frame.estimate = "e"

    def second(frame):
        log.append(("second", frame.estimate))
        frame.command = (0.2, 0.1)

    harness = Harness(OneRobot(sim), [[first, second]], before=[lambda: log.append(("before", sim.time))])
    assert harness.run(0.1) is None  # the clock reached 0.1 s
    assert log == [
        ("before", 0.0),
        ("first", 0.0, (0.0, 0.0, 0.0)),
        ("second", "e"),
        ("step", 0.2, 0.1),
        ("before", 0.05),
        ("first", 0.05, (0.2 * 0.05, 0.0, 0.0)),
        ("second", "e"),
        ("step", 0.2, 0.1),
    ]
    assert harness.steps == 2


def test_an_observation_is_what_the_nodes_see_copied():
    sim = Sim([])
    (observation,) = OneRobot(sim).observe()
    scan = observation.scan
    assert (scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max) == (-1.0, 0.5, 0.1, 3.5)
    assert scan.ranges.tolist() == [1.0, 2.0, math.inf, 3.0, 0.5]
    sim.x = 1.0
    assert scan.ranges[0] == 1.0, "the scan is the observation's, not the simulator's buffer"
    assert observation.twist == (0.1, 0.0) and observation.stamp == 0.0


def test_a_part_stopping_ends_the_run_before_the_step_and_later_parts():
    log: list = []
    sim = Sim(log)

    def stopper(frame):
        if frame.observation.stamp >= 0.1 - 1e-9:
            frame.stop = "enough"

    harness = Harness(OneRobot(sim), [[stopper, lambda frame: log.append("later"), stand]])
    assert harness.run(10.0) == "enough"
    assert log == ["later", ("step", 0.0, 0.0), "later", ("step", 0.0, 0.0)]
    assert sim.time == pytest.approx(0.1)


def test_the_stop_check_comes_before_the_clock_and_each_observation():
    sim = Sim([])
    harness = Harness(OneRobot(sim), [[stand]])
    assert harness.run(0.0, lambda: "goal") == "goal"  # checked first
    assert harness.run(0.0) is None and harness.steps == 0
    assert harness.run(1.0, lambda: "far" if sim.time > 0.12 else None) == "far" and harness.steps == 3


def test_a_robot_no_part_commands_is_an_error():
    with pytest.raises(ValueError, match="no part commanded robot 0"):
        Harness(OneRobot(Sim([])), [[lambda frame: None]]).step()


def test_robots_are_observed_and_stepped_in_the_fleets_order_with_their_own_parts():
    log: list = []

    class Fleet:
        time = 0.0
        lidar = Sim([]).lidar

        def __init__(self):
            self.robots = [Sim([]), Sim([])]
            self.robots[1].x = 1.0

        def step(self, commands):
            log.append(list(commands))
            self.time += 0.05

    fleet = Fleet()

    class Localizer:
        def update(self, odometry, scan):
            return odometry[0] + scan.ranges[0]

    class Controller:
        def compute(self, scan, v, w, stamp):
            return SimpleNamespace(v=scan.ranges[0], w=v + stamp)

    parts = [[localize(Localizer()), drive(Controller())], [stand]]
    harness = Harness(Robots(fleet), parts)
    harness.step()
    assert [frame.estimate for frame in harness.frames] == [1.0, None]
    assert log == [[(1.0, 0.1), (0.0, 0.0)]]
    with pytest.raises(ValueError, match="2 robots observed, parts for 1"):
        Harness(Robots(fleet), [[stand]]).step()


def test_no_library_loop_steps_a_simulator_but_through_the_harness():
    """The lockstep loops of amr_evaluation and amr_navigation are parts on the harness: a call
    ``<...>sim.step(...)`` or ``<...>fleet.step(...)`` there is a loop wired by hand again."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    found = []
    for path in sorted([*(root / "amr_evaluation").glob("*.py"), *(root / "amr_navigation").glob("*.py")]):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "step":
                receiver = ast.unparse(node.func.value)
                if receiver.endswith(("sim", "fleet", "simulator")):
                    found.append(f"{path.relative_to(root)}:{node.lineno}: {ast.unparse(node)}")
    assert found == []
