"""amr-evaluate refuses bad input before anything runs, binds what it documents to loopback, stops on Ctrl-C
with one line, says what a resume skips, and writes nothing when nothing ran."""

from __future__ import annotations

import ast
import os
import re
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from support.waiting import poll_until

from amr_evaluation import configs
from amr_evaluation.cli import main
from amr_evaluation.interrupt import INTERRUPTED
from amr_evaluation.parameter_check import node_specs, parameter_problems
from amr_util.environment import child_environment

ROOT = Path(__file__).resolve().parents[2]
VENV_BIN = Path(sys.executable).parent


def params_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "student.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("section", "expected"),
    [
        (
            "wall_follower:\n  ros__parameters:\n    target_distanse: 0.3\n",
            "wall_follower: target_distanse = 0.3: unknown key of wall_follower (did you mean 'target_wall_distance'?)",
        ),
        ("wall_follower:\n  ros__parameters:\n    kp: fast\n", "wall_follower: kp = 'fast': must be a number"),
        ("wall_follower:\n  ros__parameters:\n    kp: 500.0\n", "wall_follower: kp = 500.0: must be in [0, 100]"),
        (
            "wall_follower:\n  ros__parameters:\n    preferred_wall: up\n",
            "wall_follower: preferred_wall = 'up': must be one of",
        ),
        ("wall_follower:\n  ros__parameters:\n    lidar:\n      beams: 0\n", "wall_follower: lidar.beams = 0:"),
    ],
)
def test_a_bad_parameter_file_ends_the_sweep_before_any_episode_naming_file_key_and_value(
    tmp_path, capsys, section, expected
):
    path = params_file(tmp_path, section)
    out = tmp_path / "r.jsonl"
    code = main(
        [
            "--run",
            f"wall_follower={path}",
            "--worlds",
            "open_room",
            "--duration",
            "1",
            "--workers",
            "1",
            "--out",
            str(out),
            "--no-progress",
            "--no-plots",
        ]
    )
    error = capsys.readouterr().err
    assert code == 2
    assert f"{path}: {expected}" in error, error
    assert not out.exists() and not list(tmp_path.glob("r.*"))


def test_a_navigation_file_is_checked_node_by_node(tmp_path, capsys):
    path = params_file(
        tmp_path,
        "path_follower:\n  ros__parameters:\n    goal_tolerance: -1.0\n"
        "planner:\n  ros__parameters:\n    no_such_thing: 1\n",
    )
    assert main(["--run", f"navigation={path}", "--worlds", "open_room", "--list"]) == 2
    error = capsys.readouterr().err
    assert f"{path}: path_follower: goal_tolerance = -1.0: must be" in error


def test_a_good_file_passes_and_use_sim_time_is_every_node_s(tmp_path, capsys):
    path = params_file(tmp_path, "wall_follower:\n  ros__parameters:\n    kp: 5\n    use_sim_time: true\n")
    assert main(["--run", f"wall_follower={path}", "--worlds", "open_room", "--list"]) == 0
    assert len(capsys.readouterr().out.splitlines()) == 1


@pytest.mark.parametrize("variant", ["sim", "real"])
def test_the_shipped_wall_follower_configurations_pass_the_check(variant):
    _, parameters = configs.resolve("wall_follower", variant)
    assert parameter_problems("wall_follower", parameters["wall_follower"]) == []


def test_every_controller_node_has_its_statements():
    for nodes in configs.NODES.values():
        for node in nodes:
            assert node_specs(node), node


def test_a_resumed_sweep_says_how_many_episodes_it_skipped(tmp_path, capsys):
    out = tmp_path / "r.jsonl"
    arguments = [
        "--families",
        "open_room",
        "--size",
        "3",
        "--duration",
        "1",
        "--workers",
        "1",
        "--out",
        str(out),
        "--no-progress",
        "--no-plots",
    ]
    assert main([*arguments, "--seeds", "2"]) == 0
    assert "skipped" not in capsys.readouterr().out
    assert main([*arguments, "--seeds", "3"]) == 0
    assert "2 finished episode(s) skipped, 1 to run" in capsys.readouterr().out
    assert len(out.read_text().splitlines()) == 3


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_an_unreachable_scheduler_is_a_clear_error_and_writes_nothing(tmp_path, capsys):
    pytest.importorskip("distributed")
    out = tmp_path / "sub" / "r.jsonl"
    address = f"tcp://127.0.0.1:{_free_port()}"
    code = main(
        [
            "--worlds",
            "open_room",
            "--duration",
            "1",
            "--scheduler",
            address,
            "--scheduler-timeout",
            "1",
            "--out",
            str(out),
            "--no-progress",
            "--no-plots",
        ]
    )
    captured = capsys.readouterr()
    assert code == 2
    assert f"no Dask scheduler answered at {address} within 1 s" in captured.err
    assert "Traceback" not in captured.err
    assert not out.parent.exists()


STARTUP_TIMEOUT = 120.0
"""s the sweep may take to write its first record (8 s or so on a quiet machine)."""


@pytest.mark.parametrize("moment", ["starting", "running"])
@pytest.mark.parametrize("workers", ["1", "2"])
def test_ctrl_c_ends_the_sweep_with_one_line(tmp_path, workers, moment):
    """starting: at once after the first line (the pool forking its workers, the first episode importing);
    running: once the first record is written (episodes in flight, others waiting)."""
    out = tmp_path / "r.jsonl"
    process = subprocess.Popen(
        [
            str(VENV_BIN / "amr-evaluate"),
            "--families",
            "perfect",
            "--seeds",
            "8",
            "--duration",
            "120",
            "--workers",
            workers,
            "--out",
            str(out),
            "--no-progress",
            "--no-plots",
        ],
        env=child_environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        assert process.stdout.readline().startswith("amr-evaluate: 8 episodes")
        if moment == "running":
            assert poll_until(
                lambda: process.poll() is not None or (out.exists() and out.read_text().count("\n")), STARTUP_TIMEOUT
            ), f"no record within {STARTUP_TIMEOUT} s"
        assert process.poll() is None, "the sweep ended before Ctrl-C"
        os.killpg(process.pid, signal.SIGINT)  # what Ctrl-C at a terminal does: the whole foreground group
        _, error = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert (process.returncode, error.splitlines()) == (
        INTERRUPTED,
        [f"amr-evaluate: interrupted; the finished episodes are in {out} (the same command resumes)"],
    )
    if moment == "running":
        assert 1 <= len(out.read_text().splitlines()) < 8


def test_the_documented_dask_commands_bind_to_loopback():
    text = (ROOT / "docs" / "amr_evaluation.md").read_text()
    commands = re.findall(r"^\.venv/bin/dask (scheduler|worker)((?:.*\\\n)*.*)$", text, flags=re.MULTILINE)
    kinds = [kind for kind, _ in commands]
    assert "scheduler" in kinds and "worker" in kinds
    for kind, rest in commands:
        words = rest.replace("\\\n", " ").split("#")[0].split()
        assert words[words.index("--host") + 1] == "127.0.0.1", (kind, words)
        if "--no-dashboard" not in words:
            assert words[words.index("--dashboard-address") + 1].startswith("127.0.0.1:"), (kind, words)


def test_no_cluster_the_code_starts_listens_beyond_loopback():
    for path in sorted((ROOT / "amr_evaluation").glob("*.py")) + sorted((ROOT / "bench").glob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Call)
                and getattr(node.func, "id", getattr(node.func, "attr", "")) == "LocalCluster"
            ):
                given = {k.arg: k.value for k in node.keywords}
                assert "host" in given and ast.literal_eval(given["host"]) == "127.0.0.1", (
                    f"{path}: {ast.unparse(node)}"
                )
                if "dashboard_address" in given:
                    assert ast.literal_eval(given["dashboard_address"]).startswith("127.0.0.1:")
