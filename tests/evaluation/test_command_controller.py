"""amr-evaluate grades a user's own node: `--run 'command=python3 student.py' --mode ros` runs it in place of the
shipped controller, in the episode's own ROS domain, and records it; a node that never answers gives a record
saying so."""

from __future__ import annotations

import json
import sys

import pytest

from amr_evaluation import cli, configs
from amr_evaluation.episode import EpisodeSpec, run_episode

STUDENT = """
import rclpy
from geometry_msgs.msg import Twist
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

rclpy.init()
node = rclpy.create_node("student")
publisher = node.create_publisher(Twist, "cmd_vel", 10)


def on_scan(scan):  # one command per observation: straight on while the way ahead is clear
    command = Twist()
    command.linear.x = 0.2 if min(scan.ranges[:10] + scan.ranges[-10:]) > 0.4 else 0.0
    publisher.publish(command)


node.create_subscription(LaserScan, "scan", on_scan, qos_profile_sensor_data)
rclpy.spin(node)
"""
SILENT = STUDENT.replace("    publisher.publish(command)\n", "    pass\n")
AHEAD = [-0.5, -1.0, 0.2]
"""open_room's start is (-1.5, -1.0) facing +x: a goal 1 m straight ahead."""


def spec_of(tmp_path, source: str, **options) -> EpisodeSpec:
    (tmp_path / "student.py").write_text(source, encoding="utf-8")
    label, parameters = configs.command_configuration(f"{sys.executable} student.py", tmp_path)
    return EpisodeSpec(
        "command",
        label,
        parameters,
        {"file": "open_room.yaml"},
        goal=AHEAD,
        seed=1,
        duration=15.0,
        options={"answer_timeout": 3.0, **options},
        mode="ros",
    )


@pytest.mark.parametrize("clock", [{"clock": "lockstep"}, {"clock": "realtime", "pace": 2.0}], ids=lambda c: c["clock"])
def test_a_student_node_is_run_and_recorded(tmp_path, ros_domain, monkeypatch, clock):
    monkeypatch.setenv("AMR_EVALUATE_ROS_DOMAINS", f"{ros_domain}-{ros_domain}")
    # a node starting on a loaded machine (two test workers beside it) may take more than the silent case's 3 s
    record = run_episode(spec_of(tmp_path, STUDENT, **clock, answer_timeout=10.0))
    assert record["error"] is None, record["error"]
    assert record["goal_reached"] is True and record["reason"] == "goal region reached", record["reason"]
    # 0.8 m at 0.2 m/s: 4 s; in real time a node on a loaded machine misses scans and drives less of each second
    latest = 8.0 if clock["clock"] == "lockstep" else 12.0
    assert 3.9 < record["time_to_goal"] < latest and record["collisions"] == 0
    steps = record["time"] / 0.05
    # lockstep: one command per step; realtime: one per scan the node kept up with
    assert record["extra"]["commands"] >= (steps - 2 if clock["clock"] == "lockstep" else steps / 3)
    assert record["extra"]["clock"] == clock["clock"]
    assert record["extra"]["ros_domain"] == ros_domain and record["config"].startswith("command:student-")


def test_a_node_that_never_answers_gives_a_record_saying_so(tmp_path, ros_domain, monkeypatch):
    monkeypatch.setenv("AMR_EVALUATE_ROS_DOMAINS", f"{ros_domain}-{ros_domain}")
    record = run_episode(spec_of(tmp_path, SILENT))
    assert record["error"] is None, record["error"]
    assert record["reason"] == "the controller never answered: no /cmd_vel within 3 s"
    assert record["goal_reached"] is False and record["time"] == 0.0 and record["extra"]["commands"] == 0
    assert record["wall_time"] < 40.0


def test_the_command_line_and_its_file_make_the_configuration(tmp_path, monkeypatch, capsys):
    (tmp_path / "student.py").write_text("print('v1')\n", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    first = configs.resolve("command", "python3 student.py")
    (tmp_path / "student.py").write_text("print('v2')\n", encoding="utf-8")
    second = configs.resolve("command", "python3 student.py")
    assert first[0] != second[0] and first[0].startswith("command:student-")  # a changed file, a new configuration
    assert second[1]["command"]["argv"] == ["python3", "student.py"]
    with pytest.raises(configs.ConfigurationError, match="give the command"):
        configs.resolve("command", "")
    out = tmp_path / "r.jsonl"
    assert cli.main(["--run", "command=python3 student.py", "--worlds", "open_room", "--out", str(out)]) == 2
    assert "--mode ros" in capsys.readouterr().err
    options = cli.parse_arguments(
        [
            "--run",
            "command=python3 student.py",
            "--worlds",
            "open_room",
            "--mode",
            "ros",
            "--clock",
            "realtime",
            "--pace",
            "3",
        ]
    )
    [spec] = cli.build_specs(options)
    assert (spec.controller, spec.mode, spec.options["clock"], spec.options["pace"]) == (
        "command",
        "ros",
        "realtime",
        3.0,
    )
    assert json.loads(json.dumps(spec.to_dict()))["parameters"]["command"]["cwd"] == str(tmp_path.resolve())
