"""The simulator as `ros2 run amr_simulation simulator` starts it: a process, its installed parameter file."""

import sys
from pathlib import Path

import pytest
from lifecycle_msgs.msg import Transition
from support.ros import spin_until
from support.simulator_probe import MATCH_DELAY, TIMEOUT, change_state, drive, settle, state_of

PARAMS_FILE = Path(sys.prefix) / "share" / "amr_simulation" / "config" / "simulator.yaml"


def test_lockstep_drive_through_the_installed_executable(probe, executor, node_process):
    simulator = node_process(
        "amr_simulation",
        "simulator",
        "--params-file",
        str(PARAMS_FILE),
        "-p",
        "autostart:=true",
        "-p",
        "world:=open_room.yaml",
    )
    driver = probe()
    executor.add_node(driver)
    assert spin_until(executor, lambda: "simulator" in driver.get_node_names() and driver.connected(), 3 * TIMEOUT), (
        "simulator never appeared"
    )
    settle(executor, MATCH_DELAY)
    assert state_of(executor, driver) == "active"

    drive(executor, driver, [(0.15, 0.0)] * 200)  # 10 s at dt 0.05
    for stream in (driver.ground_truth, driver.odometry):
        assert stream[-1].pose.pose.position.x == pytest.approx(-1.5 + 1.5, abs=0.01)
        assert stream[-1].pose.pose.position.y == pytest.approx(-1.0, abs=0.01)
    assert driver.statuses[-1].steps == 200

    code, output = simulator.stop()
    assert code == 0 and "Traceback" not in output, output


def test_malformed_world_keeps_the_process_alive_and_unconfigured(probe, executor, node_process, tmp_path):
    world = tmp_path / "bad.yaml"
    world.write_text("walls: [[0.0, 0.0, 1.0, 0.0]]\nstart: [0.5, 0.5, 0.0]\n")  # no wall_thickness
    simulator = node_process("amr_simulation", "simulator", "-p", "autostart:=true", "-p", f"world:={world}")
    driver = probe()
    executor.add_node(driver)
    # by node name: earlier in-process simulators can leave service endpoints in this process's graph cache
    assert spin_until(
        executor, lambda: "simulator" in driver.get_node_names() and driver.get_state.service_is_ready(), 3 * TIMEOUT
    ), "simulator never appeared"
    assert state_of(executor, driver) == "unconfigured"
    assert not change_state(executor, driver, Transition.TRANSITION_CONFIGURE), "the world is still bad"
    assert simulator.process.poll() is None, "the node must survive a failed configure"

    code, output = simulator.stop()
    assert code == 0 and "Traceback" not in output, output
    assert "wall_thickness" in output and "configure failed" in output
