"""The node as `ros2 run amr_kinematics ik_service` starts it: lib/amr_kinematics/ik_service, its own process."""

from __future__ import annotations

import yaml
from lifecycle_msgs.srv import GetState
from support.ik_service import CONFIG, Probe, call, connect, pose, reached, solve_request
from support.ros import spin_for, spin_until

from amr_kinematics.config import flatten_parameters

DISCOVERY = 20.0  # s; a cold process imports numpy and rclpy, then DDS discovery takes ~1 s
SLOW = 2.0  # s, an unreachable target's solve runs to this timeout


def state_of(executor, probe, node_name: str) -> str:
    client = probe.create_client(GetState, f"/{node_name}/get_state")
    reached(executor, client, GetState.Request(), timeout=DISCOVERY)
    return call(executor, client, GetState.Request()).current_state.label


def test_process_with_the_params_file_solves(ros_context, executor, node_process):
    process = node_process("amr_kinematics", "ik_service", "--params-file", str(CONFIG), "-p", "autostart:=true")
    probe = Probe(ros_context)
    executor.add_node(probe)
    connect(executor, probe, timeout=DISCOVERY)
    assert spin_until(executor, lambda: probe.count_publishers("/ik_service/joint_states") > 0, timeout=5.0)
    reply = call(executor, probe.solve, solve_request("arm5", pose(0.053, 0.0478, 0.0)))  # empty seed: home
    assert reply.success and reply.iterations == 9, reply.message
    assert spin_until(executor, lambda: probe.joint_states, timeout=5.0)
    assert probe.joint_states[-1].name[0] == "arm5/q1"
    assert state_of(executor, probe, "ik_service") == "active"
    code, output = process.stop()
    assert code == 0 and "Traceback" not in output, output


def test_bad_chain_process_stays_unconfigured_and_says_why(ros_context, executor, node_process, tmp_path):
    params = flatten_parameters(yaml.safe_load(CONFIG.read_text(encoding="utf-8")))
    params["ur5.lower"] = params["ur5.lower"][:5]
    bad = tmp_path / "bad_chains.yaml"
    bad.write_text(yaml.safe_dump({"/**": {"ros__parameters": params}}))
    broken = node_process(
        "amr_kinematics", "ik_service", "-r", "__node:=ik_bad", "--params-file", str(bad), "-p", "autostart:=true"
    )
    # without a `chains` parameter the node serves the packaged config/ik_chains.yaml
    packaged = node_process("amr_kinematics", "ik_service", "-p", "autostart:=true")
    probe = Probe(ros_context)
    executor.add_node(probe)
    assert state_of(executor, probe, "ik_bad") == "unconfigured"
    connect(executor, probe, timeout=DISCOVERY)
    assert call(executor, probe.solve, solve_request("ur5", pose(0.3, 0.2, 0.3), timeout=1.0)).success  # load slack
    assert broken.process.poll() is None, "a bad chain must not end the process"
    code, output = broken.stop()
    assert "configure failed, nothing loaded: chain 'ur5', key 'ur5.lower'" in output, output
    assert code == 0 and "Traceback" not in output, output
    code, output = packaged.stop()
    assert "serving the packaged config/ik_chains.yaml" in output and code == 0, output


def test_a_long_solve_blocks_neither_other_chains_nor_its_own_past_their_timeouts(ros_context, executor, node_process):
    # a node process of its own, as deployed: the GIL it shares with a long solve is not shared with the client
    node_process(
        "amr_kinematics",
        "ik_service",
        "--params-file",
        str(CONFIG),
        "-p",
        "autostart:=true",
        "-p",
        f"max_timeout:={SLOW}",
        "-p",
        "max_iterations_limit:=1000000",
    )
    probe = Probe(ros_context)
    executor.add_node(probe)
    connect(executor, probe, timeout=DISCOVERY)
    slow = probe.solve.call_async(solve_request("panda", pose(2.0, 2.0, 2.0), timeout=SLOW, max_iterations=1_000_000))
    spin_for(executor, 0.3)  # the idle node takes it up within milliseconds
    reachable = solve_request("panda", pose(0.3, 0.0, 0.5), timeout=0.05)
    waiting = call(executor, probe.solve, reachable)
    assert not waiting.success
    assert "chain 'panda' stayed busy with other solves for the whole timeout" in waiting.message
    answered = 0
    while not slow.done():
        assert call(executor, probe.solve, solve_request("rr2", pose(1.0, 1.0))).success
        answered += not slow.done()
    # usually dozens; a few without the node's short GIL switch interval
    assert answered >= 3, f"only {answered} requests on another chain answered during a {SLOW} s solve"
    assert not slow.result().success and "timeout" in slow.result().message
    reachable.timeout = 1.0  # the chain is free now; the slack is for a loaded machine
    assert call(executor, probe.solve, reachable).success
