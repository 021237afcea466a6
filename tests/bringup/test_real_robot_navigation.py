"""real_robot_navigation: a TurtleBot3's own bringup under our navigation stack; its twin on the simulator in real
time reaches pillar_goal (a goal a wall follower never reaches) through localization, planning and following."""

import os
import re
import signal

import pytest
from support.bringup_run import Bringup
from support.waiting import poll_until

from amr_bringup.stack_config import load_bringup

GOAL_TIMEOUT = 90.0
"""wall-clock s for startup and the run at pace 2 (the goal comes at about 25 simulated s)."""


def test_the_real_stack_is_the_robot_bringup_and_our_nodes():
    bringup = load_bringup("real_robot_navigation").with_overrides({"map": "/maps/lab.yaml"}, {})
    nodes = {node.name: node for node in bringup.nodes}
    assert set(nodes) == {
        "map_server",
        "odometry_node",
        "wall_follower",
        "particle_filter",
        "planner",
        "path_follower",
        "navigator",
    }  # no simulator: the robot's bringup publishes /scan, /odom
    assert nodes["map_server"].parameters["yaml_filename"] == "/maps/lab.yaml"
    for name in ("wall_follower", "path_follower"):
        assert nodes[name].parameter_files == (f"{name}_real.yaml",)
        assert nodes[name].parameters["navigated"] is True


def test_the_twin_is_the_robot_on_the_simulator():
    nodes = {node.name: node for node in load_bringup("real_robot_navigation_sim").nodes}
    simulator = nodes["simulator"].parameters
    assert (simulator["mode"], simulator["cmd_vel_stamped"], simulator["publish_odometry"]) == (
        "realtime",
        False,
        False,
    )
    assert (simulator["lidar.beams"], simulator["scan_period"], simulator["dt"]) == (360, 0.2, 0.05)
    assert simulator["encoders.noise"] > 0 and simulator["lidar.noise_std"] > 0
    real = {node.name for node in load_bringup("real_robot_navigation").nodes}
    assert real <= set(nodes)


@pytest.fixture
def run(ros_domain):
    started = []
    yield lambda *arguments: started.append(Bringup(*arguments)) or started[-1]
    for bringup in started:
        if bringup.process.poll() is None:
            os.killpg(bringup.process.pid, signal.SIGKILL)


def test_the_twin_reaches_the_goal_in_real_time(run):
    bringup = run("--composed", "real_robot_navigation_sim", "pace:=2.0")
    poll_until(lambda: bringup.process.poll() is not None or "goal reached at" in bringup.output, GOAL_TIMEOUT, 0.2)
    reached = re.search(r"goal reached at \(.*\), t = ([\d.]+) s, ([\d.]+) m, (\d+) collisions", bringup.output)
    bringup.process.send_signal(signal.SIGINT)
    code = bringup.finish(30.0)
    assert reached, f"no goal within {GOAL_TIMEOUT} s:\n{bringup.output[-4000:]}"
    assert "localized at" in bringup.output  # the filter localized before the path follower drove
    assert int(reached[3]) == 0 and float(reached[1]) < 60.0
    assert code == 0, bringup.output[-2000:]
