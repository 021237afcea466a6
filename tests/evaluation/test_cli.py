"""amr-evaluate: builds the sweep from its arguments, writes records, summary and plots, refuses bad input."""

from __future__ import annotations

import json

import pytest

from amr_evaluation.cli import main


def test_a_small_sweep_writes_records_summary_and_plots(tmp_path, capsys):
    out = tmp_path / "sweep.jsonl"
    arguments = [
        "--run",
        "wall_follower=sim",
        "--run",
        "wall_follower=real",
        "--worlds",
        "open_room",
        "--families",
        "narrowing",
        "--seeds",
        "1",
        "--duration",
        "40",
        "--lidar-noise",
        "0.01",
        "--workers",
        "1",
        "--out",
        str(out),
        "--no-progress",
    ]
    assert main(arguments) == 0
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(records) == 4 and {r["config"] for r in records} == {"sim", "real"}
    assert {(r["world"], r["config"]): r["goal_reached"] for r in records}[("open_room", "sim")] is True
    table = (tmp_path / "sweep.summary.txt").read_text()
    assert "TOTAL wall_follower sim: 2 episodes" in table and "open_room" in table
    assert (tmp_path / "sweep.success.png").stat().st_size > 5000
    assert (tmp_path / "sweep.time_to_goal.png").exists()
    capsys.readouterr()
    assert main(arguments) == 0  # resumed: nothing left to run, the same summary
    assert len(out.read_text().splitlines()) == 4
    assert "TOTAL wall_follower sim: 2 episodes" in capsys.readouterr().out


def test_list_shows_every_episode_of_the_grid(capsys):
    assert main(["--families", "perfect", "bends", "--seeds", "3", "--lidar-noise", "0.01", "0.03", "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 * 3 * 2 and len({line.split()[0] for line in lines}) == 12


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--families", "perfect", "mazy"], "--families: unknown 'mazy'"),
        (["--worlds", "open_room", "--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "exclude each other"),
        (["--worlds", "open_room", "--goal", "1,2"], "--goal '1,2'"),
        (["--worlds", "open_room", "--mode", "ros", "--ros-domains", "60-50"], "--ros-domains '60-50'"),
    ],
)
def test_bad_arguments_are_refused_naming_them(arguments, message, capsys):
    with pytest.raises(SystemExit):
        main(arguments)
    assert message in capsys.readouterr().err


def test_an_unknown_controller_or_world_is_named(capsys):
    assert main(["--run", "wall_folower", "--worlds", "open_room"]) == 2
    assert "unknown controller 'wall_folower'" in capsys.readouterr().err
    assert main(["--worlds", "atlantis"]) == 2
    assert "atlantis" in capsys.readouterr().err
