"""The simulator node in realtime mode: a timer steps, /clock leads, stale commands time out."""

import math
import time

import pytest
from conftest import spin_until
from lifecycle_msgs.msg import Transition
from simulator_probe import TIMEOUT, Probe, seconds, settle, simulator, start  # noqa: F401 (fixture)

DT = 0.05
RATE = 4.0
REALTIME = {"world": "open_room.yaml", "mode": "realtime", "rate": RATE}


def sim_time(probe: Probe) -> float:
    return seconds(probe.clocks[-1].clock) if probe.clocks else 0.0


def moving_steps(probe: Probe) -> int:
    return sum(1 for m in probe.ground_truth if m.twist.twist.linear.x > 0.1)


def test_clock_leads_and_a_stale_command_stops_the_robot(simulator, ros_context, executor):
    node = simulator(command_timeout=0.5, **REALTIME)
    probe = Probe(ros_context, use_sim_time=True)
    start(executor, node, probe)
    assert spin_until(executor, lambda: sim_time(probe) >= 0.5, TIMEOUT)

    probe.send(0.2)
    wall_start, sim_start = time.monotonic(), sim_time(probe)
    assert spin_until(executor, lambda: sim_time(probe) >= sim_start + 1.5, TIMEOUT)
    wall_elapsed, sim_elapsed = time.monotonic() - wall_start, sim_time(probe) - sim_start

    # the command ran for command_timeout (plus at most the step that found it stale), then stop
    assert moving_steps(probe) in (10, 11)
    assert probe.ground_truth[-1].twist.twist.linear.x == 0.0
    clock = [seconds(m.clock) for m in probe.clocks]
    assert [b - a for a, b in zip(clock, clock[1:])] == pytest.approx([DT] * (len(clock) - 1))
    assert seconds(probe.ground_truth[-1].header.stamp) <= clock[-1]
    # a node with use_sim_time follows /clock
    assert probe.get_clock().now().nanoseconds * 1e-9 == pytest.approx(clock[-1], abs=2 * DT)
    assert sim_elapsed / wall_elapsed > 1.5, f"rate {RATE} should run well faster than real time"


def test_timeout_zero_disables_it_and_non_finite_commands_are_ignored(simulator, ros_context, executor):
    node, probe = simulator(command_timeout=0.0, **REALTIME), Probe(ros_context)
    start(executor, node, probe)
    probe.send(0.2)
    assert spin_until(executor, lambda: moving_steps(probe) > 0, TIMEOUT)
    probe.send(math.nan)
    probe.send(0.1, math.inf)
    moving_since = sim_time(probe)
    assert spin_until(executor, lambda: sim_time(probe) >= moving_since + 1.0, TIMEOUT)
    assert node.state_label == "active"
    assert probe.ground_truth[-1].twist.twist.linear.x == pytest.approx(0.2), "still the last finite command"


def test_deactivation_stops_the_clock_and_drops_the_command(simulator, ros_context, executor):
    node, probe = simulator(command_timeout=0.0, **REALTIME), Probe(ros_context)
    start(executor, node, probe)
    probe.send(0.2)
    assert spin_until(executor, lambda: moving_steps(probe) > 0, TIMEOUT)
    assert node.try_transition(Transition.TRANSITION_DEACTIVATE)
    settle(executor)
    count = len(probe.clocks)
    settle(executor, 0.3)
    assert len(probe.clocks) == count, "an inactive simulator does not step"

    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: len(probe.clocks) > count + 5, TIMEOUT)
    assert probe.ground_truth[-1].twist.twist.linear.x == 0.0, "the held command was zeroed"
