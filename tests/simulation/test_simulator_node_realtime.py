"""The simulator node in realtime mode: a timer steps, /clock leads, stale commands time out."""

import math
import time
from itertools import pairwise

import pytest
from lifecycle_msgs.msg import Transition
from support.ros import spin_until
from support.simulator_probe import TIMEOUT, Probe, seconds, settle, start

DT = 0.05
RATE = 4.0
REALTIME = {"world": "open_room.yaml", "mode": "realtime", "rate": RATE}


def sim_time(driver: Probe) -> float:
    return seconds(driver.clocks[-1].clock) if driver.clocks else 0.0


def moving_steps(driver: Probe) -> int:
    return sum(1 for m in driver.ground_truth if m.twist.twist.linear.x > 0.1)


def test_clock_leads_and_a_stale_command_stops_the_robot(simulator, probe, executor):
    node = simulator(command_timeout=0.5, **REALTIME)
    driver = probe(use_sim_time=True)
    start(executor, node, driver)
    assert spin_until(executor, lambda: sim_time(driver) >= 0.5, TIMEOUT)

    driver.send(0.2)
    wall_start, sim_start = time.monotonic(), sim_time(driver)
    assert spin_until(executor, lambda: sim_time(driver) >= sim_start + 1.5, TIMEOUT)
    wall_elapsed, sim_elapsed = time.monotonic() - wall_start, sim_time(driver) - sim_start

    # the command ran for command_timeout (plus at most the step that found it stale), then stop
    assert moving_steps(driver) in (10, 11)
    assert driver.ground_truth[-1].twist.twist.linear.x == 0.0
    clock = [seconds(m.clock) for m in driver.clocks]
    assert [b - a for a, b in pairwise(clock)] == pytest.approx([DT] * (len(clock) - 1))
    assert seconds(driver.ground_truth[-1].header.stamp) <= clock[-1]
    # a node with use_sim_time follows /clock
    assert driver.get_clock().now().nanoseconds * 1e-9 == pytest.approx(clock[-1], abs=2 * DT)
    assert sim_elapsed / wall_elapsed > 1.5, f"rate {RATE} should run well faster than real time"


def test_timeout_zero_disables_it_and_non_finite_commands_are_ignored(simulator, probe, executor):
    node, driver = simulator(command_timeout=0.0, **REALTIME), probe()
    start(executor, node, driver)
    driver.send(0.2)
    assert spin_until(executor, lambda: moving_steps(driver) > 0, TIMEOUT)
    driver.send(math.nan)
    driver.send(0.1, math.inf)
    moving_since = sim_time(driver)
    assert spin_until(executor, lambda: sim_time(driver) >= moving_since + 1.0, TIMEOUT)
    assert node.state_label == "active"
    assert driver.ground_truth[-1].twist.twist.linear.x == pytest.approx(0.2), "still the last finite command"


def test_deactivation_stops_the_clock_and_drops_the_command(simulator, probe, executor):
    node, driver = simulator(command_timeout=0.0, **REALTIME), probe()
    start(executor, node, driver)
    driver.send(0.2)
    assert spin_until(executor, lambda: moving_steps(driver) > 0, TIMEOUT)
    assert node.try_transition(Transition.TRANSITION_DEACTIVATE)
    settle(executor)
    count = len(driver.clocks)
    settle(executor, 0.3)
    assert len(driver.clocks) == count, "an inactive simulator does not step"

    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: len(driver.clocks) > count + 5, TIMEOUT)
    assert driver.ground_truth[-1].twist.twist.linear.x == 0.0, "the held command was zeroed"


def test_scan_period_publishes_the_lidar_at_its_own_rate(simulator, probe, executor):
    """A TurtleBot3's LDS-01 at 5 Hz beside 20 Hz odometry: a scan every fourth step, stamped on it."""
    node, driver = simulator(scan_period=0.2, **REALTIME), probe()
    start(executor, node, driver)
    assert spin_until(executor, lambda: len(driver.odometry) >= 41, TIMEOUT)
    odometry, scans = len(driver.odometry), len(driver.scans)
    assert odometry / 4 - 2 <= scans <= odometry / 4 + 2
    stamps = [seconds(m.header.stamp) for m in driver.scans]
    assert [b - a for a, b in pairwise(stamps)] == pytest.approx([0.2] * (len(stamps) - 1))
