"""amr-bringup end to end: the stack reaches active, Ctrl-C/SIGTERM leave no process behind, failures name the node."""

import os
import re
import signal
import time

import pytest
from lifecycle_msgs.srv import GetState
from rclpy.node import Node
from support.bringup_run import Bringup
from support.ros import spin_until
from support.waiting import poll_until

STARTUP_TIMEOUT = 30.0


@pytest.fixture
def bringups(ros_domain):
    """Starts amr-bringup runs in this test's own DDS domain (no ghosts of earlier tests' stacks)."""
    started: list[Bringup] = []

    def start(*arguments: str) -> Bringup:
        started.append(Bringup(*arguments))
        return started[-1]

    yield start
    for run in started:
        if run.process.poll() is None:
            os.killpg(run.process.pid, signal.SIGKILL)
        for pid in run.child_pids().values():
            try:
                os.killpg(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


class StateProbe(Node):
    def __init__(self, context, names):
        super().__init__("bringup_probe", context=context)
        self.clients_ = {name: self.create_client(GetState, f"/{name}/get_state") for name in names}
        self.states = {name: None for name in names}

    def ask(self):
        for name, client in self.clients_.items():
            if client.service_is_ready():
                future = client.call_async(GetState.Request())
                future.add_done_callback(
                    lambda f, name=name: self.states.update({name: f.result().current_state.label})
                )


def wait_until_active(executor, probe: StateProbe, run: Bringup) -> None:
    deadline = time.monotonic() + STARTUP_TIMEOUT
    while time.monotonic() < deadline and run.process.poll() is None:
        probe.ask()
        if spin_until(executor, lambda: all(s == "active" for s in probe.states.values()), 0.5):
            return
    pytest.fail(f"states {probe.states} after {STARTUP_TIMEOUT} s:\n{run.output}")


def assert_gone(pids: dict[str, int]) -> None:
    for pid in pids.values():
        for probe in (os.kill, os.killpg):  # the process, and its session's process group
            with pytest.raises(ProcessLookupError):
                probe(pid, 0)


def test_processes_reach_active_show_status_and_leave_nothing_behind_on_ctrl_c(ros_context, executor, bringups):
    run = bringups("real_robot", "--status")
    probe = StateProbe(ros_context, ["odometry_node", "wall_follower"])
    executor.add_node(probe)
    wait_until_active(executor, probe, run)
    pids = run.child_pids()
    assert set(pids) == {"odometry_node", "wall_follower"} and os.getpid() not in pids.values()
    status = (r"^odometry_node\s+active$", r"^/cmd_vel\s+geometry_msgs/msg/Twist\s+\d+\.\d\s+wall_follower$")
    assert poll_until(lambda: all(re.search(line, run.output, re.MULTILINE) for line in status), STARTUP_TIMEOUT), (
        f"no status table with both nodes active and /cmd_vel flowing within {STARTUP_TIMEOUT} s:\n{run.output}"
    )
    run.process.send_signal(signal.SIGINT)
    assert run.finish() == 0, run.output
    assert_gone(pids)
    output = run.output
    assert "deactivate wall_follower: wall_follower is inactive" in output  # the manager took it down first
    assert "[wall_follower] " in output  # child lines carry their node's name


def test_composed_stack_reaches_active_in_one_process_and_stops_on_sigterm(ros_context, executor, bringups):
    run = bringups("real_robot", "--composed")
    probe = StateProbe(ros_context, ["odometry_node", "wall_follower"])
    executor.add_node(probe)
    wait_until_active(executor, probe, run)
    assert run.child_pids() == {}
    run.process.send_signal(signal.SIGTERM)
    assert run.finish() == 0, run.output
    assert "cleanup odometry_node: odometry_node is unconfigured" in run.output


def test_a_stop_during_startup_takes_down_every_node_that_came_up(bringups):
    run = bringups("real_robot", "--composed")
    first_up = "configure odometry_node: odometry_node is inactive"
    poll_until(lambda: first_up in run.output or run.process.poll() is not None, STARTUP_TIMEOUT, period=0.005)
    run.process.send_signal(signal.SIGTERM)  # the manager is still bringing the stack up
    assert run.finish() == 0, run.output
    assert first_up in run.output and "cleanup odometry_node: odometry_node is unconfigured" in run.output, run.output
    if "configure wall_follower: wall_follower is inactive" in run.output:
        assert "cleanup wall_follower: wall_follower is unconfigured" in run.output, run.output


def test_duration_stops_the_stack_by_itself(bringups):
    run = bringups("ik_service", "--duration", "6")
    assert run.finish(timeout=30.0) == 0, run.output
    assert "all nodes active: ik_service" in run.output
    assert_gone(run.child_pids())


def write(tmp_path, text):
    path = tmp_path / "stack.yaml"
    path.write_text(text)
    return str(path)


def unparsable_parameter_file(tmp_path) -> str:
    """A parameter file rcl cannot parse (a list mixing ints and floats): the node process cannot start."""
    path = tmp_path / "broken.yaml"
    path.write_text("odometry_node:\n  ros__parameters:\n    qos_depth: [1, 2.5]\n")
    return str(path)


def test_a_node_that_dies_stops_everything_and_is_named(tmp_path, bringups):
    stack = write(
        tmp_path,
        f"""
nodes:
  - {{name: wall_follower, package: amr_control, executable: wall_follower, parameter_files: [wall_follower_real.yaml]}}
  - {{name: odometry_node, package: amr_turtlebot3, executable: odometry_node,
     parameter_files: [{unparsable_parameter_file(tmp_path)}]}}
""",
    )
    run = bringups(stack)
    assert run.finish(timeout=30.0) == 1
    assert re.search(r"amr-bringup: node odometry_node \(pid \d+\) exited with code 1", run.output), run.output
    assert_gone(run.child_pids())


def test_a_failed_configure_stops_the_startup_and_names_the_node(tmp_path, bringups):
    stack = write(
        tmp_path,
        """
nodes:
  - {name: wall_follower, package: amr_control, executable: wall_follower, parameter_files: [wall_follower_real.yaml],
     parameters: {preferred_wall: middle}}
""",
    )
    run = bringups(stack, "--composed")
    assert run.finish(timeout=30.0) == 1
    assert "amr-bringup: startup failed at configure of wall_follower" in run.output, run.output


def test_a_missing_executable_is_refused_before_anything_starts(tmp_path, bringups):
    stack = write(tmp_path, "nodes: [{name: ghost, package: amr_control, executable: no_such_node}]\n")
    run = bringups(stack)
    assert run.finish() == 2
    assert "nodes[0].executable: ghost: " in run.output and "is missing or not executable" in run.output
    assert run.child_pids() == {}


def test_a_node_that_cannot_be_built_in_composed_mode_is_named(tmp_path, bringups):
    stack = write(
        tmp_path,
        f"""
nodes:
  - {{name: odometry_node, package: amr_turtlebot3, executable: odometry_node,
     parameter_files: [{unparsable_parameter_file(tmp_path)}]}}
""",
    )
    run = bringups(stack, "--composed")
    assert run.finish(timeout=30.0) == 1
    assert "amr-bringup: node odometry_node failed to start: RCLInvalidROSArgsError" in run.output, run.output


def test_a_bad_parameter_fails_configure_naming_node_and_key(tmp_path, bringups):
    stack = write(
        tmp_path,
        """
nodes:
  - {name: odometry_node, package: amr_turtlebot3, executable: odometry_node,
     parameters: {qos_depth: -4, input_topik: odom}}
""",
    )
    run = bringups(stack)
    assert run.finish(timeout=30.0) == 1
    assert "[odometry_node]: configure failed: qos_depth: must be in [1, 1000], got -4" in run.output, run.output
    assert (
        "configure failed: input_topik: unknown parameter (known: input_topic, output_topic, qos_depth)" in run.output
    ), run.output
    assert "startup failed at configure of odometry_node" in run.output, run.output


def test_arguments_and_parameters_on_the_command_line_reach_the_nodes(bringups):
    run = bringups("maze_sim", "world:=hard_maze.yaml", "-p", "wall_follower.kp:=3.0", "--composed", "--duration", "1")
    assert run.finish(timeout=30.0) == 0, run.output
    assert "world hard_maze (" in run.output, run.output
    typo = bringups("maze_sim", "-p", "wall_follower.kpp:=10.0", "--composed")
    assert typo.finish(timeout=30.0) == 1
    assert "configure failed: kpp: unknown parameter (known: " in typo.output, typo.output
