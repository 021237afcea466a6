"""The simulator's controls for watching a run: pause, resume, step and the live pace, in lockstep and
realtime; a paused and stepped lockstep run is the run it would have been."""

import pytest
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger
from support.ros import spin_until
from support.simulator_probe import TIMEOUT, call, drive, seconds, settle, start

OPEN_ROOM = {"world": "open_room.yaml"}
COMMANDS = [(0.2, 0.0), (0.2, 0.5), (0.1, -0.8), (0.22, 0.3), (0.0, 1.0), (0.15, 0.0)]


def clients(driver):
    return {name: driver.create_client(Trigger, f"simulator/{name}") for name in ("pause", "resume", "step")}


def trigger(executor, client) -> Trigger.Response:
    return call(executor, client, Trigger.Request())


def poses(driver) -> list[tuple[float, float]]:
    return [(m.pose.pose.position.x, m.pose.pose.position.y) for m in driver.ground_truth]


def test_pause_holds_the_answering_command_and_resume_steps_it(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    control = clients(driver)
    start(executor, node, driver)
    drive(executor, driver, [(0.2, 0.0)] * 3)
    answer = trigger(executor, control["pause"])
    assert answer.success and answer.message.startswith("paused at t = 0.15 s (step 3)"), answer.message

    driver.send(0.2, 0.0)
    settle(executor, 0.5)
    assert driver.observations() == 4, "paused: the command is held, not stepped"
    assert [s.steps for s in driver.statuses] == [0, 1, 2, 3]

    answer = trigger(executor, control["resume"])
    assert answer.success and answer.message.startswith("running"), answer.message
    assert spin_until(executor, lambda: driver.observations() == 5, TIMEOUT), "resume steps the held command"
    settle(executor)
    assert driver.statuses[-1].steps == 4 and driver.observations() == 5
    drive(executor, driver, [(0.2, 0.0)])
    assert driver.statuses[-1].steps == 5
    assert "already running" in trigger(executor, control["resume"]).message


def test_step_advances_exactly_one_step_per_request(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    control = clients(driver)
    start(executor, node, driver)
    drive(executor, driver, [(0.1, 0.0)] * 2)

    answer = trigger(executor, control["step"])  # running: it pauses first; no command held: one step owed
    assert answer.success and answer.message.startswith("paused; 1 step(s) owed"), answer.message
    driver.send(0.1, 0.0)
    assert spin_until(executor, lambda: driver.observations() == 4, TIMEOUT), "the owed step runs on the next command"
    driver.send(0.1, 0.0)  # the answer to that observation is held
    settle(executor, 0.5)
    assert driver.observations() == 4

    for expected_steps in (4, 5, 6):
        answer = trigger(executor, control["step"])
        assert answer.success and answer.message.startswith(f"stepped to t = {expected_steps * 0.05:.2f} s"), (
            answer.message
        )
        assert spin_until(executor, lambda steps=expected_steps: driver.statuses[-1].steps == steps, TIMEOUT)
        driver.send(0.1, 0.0)
        settle(executor, 0.2)
        assert driver.statuses[-1].steps == expected_steps, "one step per request, no more"
    assert len(driver.statuses) == 7


def test_a_paused_and_stepped_run_is_the_run_it_would_have_been(simulator, probe, executor):
    straight = probe()
    plain = simulator(**OPEN_ROOM)
    start(executor, plain, straight)
    drive(executor, straight, COMMANDS)
    expected = poses(straight)
    executor.remove_node(plain)
    executor.remove_node(straight)
    plain.destroy_node()
    straight.destroy_node()

    node, driver = simulator(**OPEN_ROOM), probe()
    control = clients(driver)
    start(executor, node, driver)
    trigger(executor, control["pause"])
    for index, (v, w) in enumerate(COMMANDS):
        driver.send(v, w)
        if index % 2:
            trigger(executor, control["step"])
        else:
            trigger(executor, control["resume"])
            assert spin_until(executor, lambda index=index: driver.observations() == index + 2, TIMEOUT)
            trigger(executor, control["pause"])
        assert spin_until(executor, lambda index=index: driver.observations() == index + 2, TIMEOUT)
    assert poses(driver) == expected, "the same poses, bit for bit"


def test_the_pace_holds_commands_for_its_timer_and_is_live(simulator, probe, executor):
    node, driver = simulator(pace=0.001, **OPEN_ROOM), probe()  # one step per 50 s
    start(executor, node, driver)
    driver.send(0.2, 0.0)
    settle(executor, 0.5)
    assert driver.observations() == 1, "held until the pace timer releases it"
    node.set_parameters([Parameter("pace", value=0.0)])
    assert spin_until(executor, lambda: driver.observations() == 2, TIMEOUT), "pace 0 releases it at once"
    drive(executor, driver, [(0.2, 0.0)] * 3)
    result = node.set_parameters([Parameter("pace", value=20.0)])[0]
    assert result.successful, result.reason
    drive(executor, driver, [(0.2, 0.0)] * 3)  # 20 x real time: a step per 2.5 ms of wall time at most
    assert driver.statuses[-1].steps == 7
    assert not node.set_parameters([Parameter("pace", value=-1.0)])[0].successful


def test_realtime_mode_pauses_steps_and_paces(simulator, probe, executor):
    node, driver = simulator(mode="realtime", rate=5.0, **OPEN_ROOM), probe()
    control = clients(driver)
    start(executor, node, driver)
    assert spin_until(executor, lambda: driver.observations() >= 5, TIMEOUT), "the timer steps"
    trigger(executor, control["pause"])
    settle(executor, 0.3)
    count = driver.observations()
    settle(executor, 0.5)
    assert driver.observations() == count, "paused: no step"
    trigger(executor, control["step"])
    assert spin_until(executor, lambda: driver.observations() == count + 1, TIMEOUT)
    settle(executor, 0.5)
    assert driver.observations() == count + 1
    node.set_parameters([Parameter("pace", value=0.001)])  # a tick per 50 s
    trigger(executor, control["resume"])
    settle(executor, 0.5)
    assert driver.observations() == count + 1, "pace replaces rate: the next tick is 50 s away"
    node.set_parameters([Parameter("pace", value=0.0)])  # back to rate 5
    assert spin_until(executor, lambda: driver.observations() >= count + 4, TIMEOUT)


def test_controls_are_refused_unless_active(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    control = clients(driver)
    executor.add_node(node)
    executor.add_node(driver)
    from lifecycle_msgs.msg import Transition

    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    for name, client in control.items():
        answer = trigger(executor, client)
        assert not answer.success and answer.message == f"simulator is inactive: ~/{name} answers only while active"


def test_reset_while_paused_drops_the_held_command_and_stays_paused(simulator, probe, executor):
    node, driver = simulator(**OPEN_ROOM), probe()
    control = clients(driver)
    start(executor, node, driver)
    drive(executor, driver, [(0.2, 0.0)] * 2)
    trigger(executor, control["pause"])
    driver.send(0.2, 0.0)
    settle(executor, 0.3)
    assert call(executor, driver.reset, Trigger.Request()).success
    assert spin_until(executor, lambda: driver.observations() == 4, TIMEOUT), "reset publishes the start"
    assert driver.statuses[-1].steps == 0
    driver.send(0.2, 0.0)  # the answer to the reset's observation: held, still paused
    settle(executor, 0.4)
    assert driver.observations() == 4
    trigger(executor, control["step"])
    assert spin_until(executor, lambda: driver.observations() == 5, TIMEOUT)
    assert driver.statuses[-1].steps == 1
    assert driver.ground_truth[-1].pose.pose.position.x == pytest.approx(-1.5 + 0.2 * 0.05)


def clock_seconds(driver) -> list[float]:
    return [seconds(m.clock) for m in driver.clocks]


def test_a_held_robot_pauses_without_resends_and_steps_at_zero_velocity(simulator, probe, executor):
    """A driver that holds the robot (a navigator with nobody driving) sends no /cmd_vel: while running the
    observation is resent; paused, /clock stops exactly; Step takes its step at zero velocity once no /cmd_vel has
    come for lockstep_resend_period."""
    node, driver = simulator(**OPEN_ROOM, lockstep_resend_period=0.3), probe()
    control = clients(driver)
    start(executor, node, driver)
    drive(executor, driver, [(0.2, 0.0)] * 2)
    count = len(driver.clocks)
    assert spin_until(executor, lambda: len(driver.clocks) > count, TIMEOUT), "running: the observation is resent"
    assert clock_seconds(driver)[-1] == pytest.approx(0.10), "a resend does not advance time"

    assert trigger(executor, control["pause"]).success
    settle(executor, 0.2)
    count = len(driver.clocks)
    settle(executor, 1.0)
    assert len(driver.clocks) == count, "paused: nothing is resent"

    answer = trigger(executor, control["step"])  # no /cmd_vel for longer than the period: stepped at once
    assert answer.success and answer.message.startswith("stepped to t = 0.15 s (step 3)"), answer.message
    assert spin_until(executor, lambda: len(driver.clocks) == count + 1, TIMEOUT)
    x = driver.ground_truth[-1].pose.pose.position.x
    answer = trigger(executor, control["step"])  # just stepped: owed, taken when no /cmd_vel comes for the period
    assert answer.success and "1 step(s) owed" in answer.message, answer.message
    assert spin_until(executor, lambda: len(driver.clocks) == count + 2, TIMEOUT), "the owed step is taken"
    settle(executor, 1.0)
    assert clock_seconds(driver)[count:] == pytest.approx([0.15, 0.20]), "exactly one dt per Step, nothing resent"
    assert driver.statuses[-1].steps == 4
    assert abs(driver.ground_truth[-1].twist.twist.linear.x) < 0.2, "stepped at zero velocity: the robot slows"
    assert driver.ground_truth[-1].pose.pose.position.x - x < 0.2 * 0.05

    assert trigger(executor, control["resume"]).success
    count = len(driver.clocks)
    assert spin_until(executor, lambda: len(driver.clocks) > count, TIMEOUT), "running again: resends resume"
    assert clock_seconds(driver)[-1] == pytest.approx(0.20)
