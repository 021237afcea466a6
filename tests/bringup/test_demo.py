"""The main job on a short span: the same code path as `make demo`, checked through its summary.json."""

import json
import subprocess
import sys

from support.ros import ROOT

from amr_util.environment import child_environment

FIGURES = [
    "maze.png",
    "wall_distance.png",
    "localization.png",
    "localization_error.png",
    "navigation.png",
    "ik_dls.png",
    "ik_ccd.png",
    "ik_2r_path.png",
]


def test_demo_writes_figures_and_a_sound_summary(tmp_path, ros_domain):  # a domain of its own: no ghost /map
    out = tmp_path / "out"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "amr_bringup.demo",
            "--duration",
            "40",
            "--localization-duration",
            "25",
            "--out",
            str(out),
        ],
        cwd=ROOT,
        env=child_environment(),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "collisions" in result.stdout and "x real time" in result.stdout, "no progress line"
    summary = json.loads((out / "summary.json").read_text())
    maze = summary["maze"]
    assert maze["collisions"] == 0
    assert maze["goal_reached"] or maze["simulated_time_s"] >= 40.0
    assert maze["distance_m"] > 0.05 * 40.0, "the robot stalled"
    localization = summary["localization"]  # the seed maze localizes in 7-13 s through ROS (bench_localization.py)
    assert localization["localized"] and localization["collisions"] == 0, localization
    assert (
        localization["error_at_first_localized_cm"] <= 10.0
        and localization["heading_error_at_first_localized_deg"] <= 10.0
    )
    navigation = summary["navigation"]  # explore, localize, plan, go: a goal the wall follower never reaches
    assert navigation["goal_reached"] and navigation["collisions"] == 0, navigation
    assert navigation["first_localized_s"] is not None and navigation["plans"] >= 1, navigation
    ik = summary["ik"]
    assert ik["arm5_dls"]["success"] and ik["arm5_dls"]["iterations"] == 9
    assert ik["ull5_ccd"]["success"]
    assert ik["rr2_path"]["successes"] == ik["rr2_path"]["waypoints"]
    assert ik["rr2_path"]["largest_joint_step_deg"] < 15.0, "the 2R path jumped between branches"
    assert ik["ur5_position"]["success"] and ik["panda_position"]["success"]
    for name in FIGURES:
        picture = out / name
        assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
        assert picture.stat().st_size > 20_000, f"{name} looks empty"
    from PIL import Image  # the animation of the run, drawn from the bag the demo recorded

    with Image.open(out / "maze.gif") as gif:
        assert gif.format == "GIF" and gif.n_frames >= 100
    assert (out / "maze.gif").stat().st_size < 4_000_000
    assert (out / "maze_run" / "metadata.yaml").is_file() and maze["animation"]["bag"] == "maze_run"
