"""The node as `ros2 run amr_kinematics ik_service` starts it: lib/amr_kinematics/ik_service, its own process."""

from __future__ import annotations

import yaml
from lifecycle_msgs.srv import GetState

from amr_kinematics.config import flatten_parameters

from ik_node_helpers import CONFIG, Probe, call, pose, solve_request, spin_until

DISCOVERY = 20.0  # s; a cold process imports numpy and rclpy, then DDS discovery takes ~1 s


def state_of(executor, probe, node_name: str) -> str:
    client = probe.create_client(GetState, f"/{node_name}/get_state")
    assert client.wait_for_service(timeout_sec=DISCOVERY), f"{node_name} never appeared"
    return call(executor, client, GetState.Request()).current_state.label


def test_process_with_the_params_file_solves(ros_context, executor, node_process):
    process = node_process("amr_kinematics", "ik_service", "--params-file", str(CONFIG), "-p", "autostart:=true")
    probe = Probe(ros_context)
    executor.add_node(probe)
    assert probe.solve.wait_for_service(timeout_sec=DISCOVERY), "/solve_ik never appeared"
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
    broken = node_process("amr_kinematics", "ik_service", "-r", "__node:=ik_bad", "--params-file", str(bad),
                          "-p", "autostart:=true")
    # without a `chains` parameter the node serves the packaged config/ik_chains.yaml
    packaged = node_process("amr_kinematics", "ik_service", "-p", "autostart:=true")
    probe = Probe(ros_context)
    executor.add_node(probe)
    assert state_of(executor, probe, "ik_bad") == "unconfigured"
    assert probe.solve.wait_for_service(timeout_sec=DISCOVERY)
    assert call(executor, probe.solve, solve_request("ur5", pose(0.3, 0.2, 0.3))).success
    assert broken.process.poll() is None, "a bad chain must not end the process"
    code, output = broken.stop()
    assert "configure failed, nothing loaded: chain 'ur5', key 'ur5.lower'" in output, output
    assert code == 0 and "Traceback" not in output, output
    code, output = packaged.stop()
    assert "serving the packaged config/ik_chains.yaml" in output and code == 0, output
