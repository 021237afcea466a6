"""Episodes are pure functions of their spec; configurations and worlds are resolved into it, errors named."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from support.evaluation import tiny_specs

from amr_evaluation import configs
from amr_evaluation.episode import RECORD_FIELDS, EpisodeSpec, run_episode, stack_map
from amr_evaluation.records import without_timing
from amr_evaluation.worlds import WorldSpecError, build_world, world_spec_of_file
from amr_maps.map_io import load_map, save_map
from amr_maps.rasterize import rasterize_world


def test_same_spec_same_key_and_record_other_spec_other_key():
    spec = tiny_specs(1)[0]
    again = EpisodeSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again.key == spec.key
    first, second = run_episode(spec), run_episode(again)
    assert set(first) == set(RECORD_FIELDS)
    assert first["error"] is None and first["time"] == pytest.approx(spec.duration, abs=0.06)
    assert without_timing(first) == without_timing(second)
    changed = dataclasses.replace(spec, lidar_noise=0.03)
    assert changed.key != spec.key
    other = run_episode(changed)
    assert other["distance"] != first["distance"] or other["wall_error_run"] != first["wall_error_run"]


def test_a_parameter_change_changes_the_key():
    spec = tiny_specs(1)[0]
    parameters = {"wall_follower": {**spec.parameters["wall_follower"], "kp": 3.0}}
    assert dataclasses.replace(spec, parameters=parameters).key != spec.key


def test_records_are_json_with_no_nan():
    record = run_episode(tiny_specs(1, duration=1.0)[0])
    text = json.dumps(record, allow_nan=False)  # raises on NaN or infinity
    assert json.loads(text)["key"] == record["key"]


def test_navigation_episode_localizes_plans_and_reaches_a_shipped_goal():
    label, parameters = configs.resolve("navigation", "default")
    record = run_episode(
        EpisodeSpec("navigation", label, parameters, {"file": "pillar_goal.yaml"}, seed=0, duration=40.0)
    )
    assert record["error"] is None
    assert record["goal_reached"] is True and record["time_to_goal"] < 40.0
    assert record["time_to_localized"] is not None and record["time_to_localized"] < record["time_to_goal"]
    assert record["plans"] >= 1 and record["planning_time"] > 0.0
    assert record["collisions"] == 0


def test_a_failing_episode_gives_a_record_naming_the_problem():
    spec = dataclasses.replace(tiny_specs(1)[0], world={"family": "no_such_family", "seed": 0})
    record = run_episode(spec)
    assert "no_such_family" in record["error"]
    assert record["key"] == spec.key


def test_user_parameter_file_is_laid_over_the_shipped_config(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text("wall_follower:\n  ros__parameters:\n    kp: 3.0\n    linear_speed: 0.1\n")
    label, parameters = configs.resolve("wall_follower", str(path))
    sim = configs.shipped_parameters("wall_follower", "sim")
    assert parameters["wall_follower"] == {**sim, "kp": 3.0, "linear_speed": 0.1}
    assert label.startswith("sim:mine-") and len(label) == len("sim:mine-") + 8
    _, real = configs.resolve("wall_follower", f"real:{path}")
    assert real["wall_follower"]["flip_angular_sign"] is True and real["wall_follower"]["kp"] == 3.0


def test_bad_configurations_are_named(tmp_path):
    with pytest.raises(configs.ConfigurationError, match="unknown controller 'wall_folower'"):
        configs.resolve("wall_folower", "sim")
    with pytest.raises(configs.ConfigurationError, match="neither a shipped one"):
        configs.resolve("wall_follower", "fast")
    path = tmp_path / "nav.yaml"
    path.write_text("simulator:\n  ros__parameters:\n    dt: 0.1\n")
    with pytest.raises(configs.ConfigurationError, match="nav.yaml: section 'simulator' is not a node"):
        configs.resolve("navigation", str(path))


def test_user_world_file_travels_inside_the_spec(tmp_path):
    path = tmp_path / "box.yaml"
    path.write_text(
        "wall_thickness: 0.05\nwalls: [[0, 0, 2, 0], [2, 0, 2, 2], [2, 2, 0, 2], [0, 2, 0, 0]]\n"
        "start: [0.5, 0.5, 0.0]\n"
    )
    spec = world_spec_of_file(str(path))
    assert spec["name"] == "box" and spec["data"]["start"] == [0.5, 0.5, 0.0]
    assert world_spec_of_file("hard_maze.yaml") == {"file": "hard_maze.yaml"}
    with pytest.raises(WorldSpecError, match="nowhere.yaml"):
        world_spec_of_file("nowhere.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("walls: [[0, 0, 2, 0]]\nstart: [0.5, 0.5, 0.0]\n")
    with pytest.raises(WorldSpecError, match="bad.yaml.*wall_thickness"):
        world_spec_of_file(str(bad))


def test_localization_episode_localizes_and_plan_follow_reaches_the_goal():
    label, parameters = configs.resolve("localization", "default")
    record = run_episode(
        EpisodeSpec("localization", label, parameters, {"file": "inner_maze.yaml"}, seed=0, duration=8.0)
    )  # localized at about 5 s
    assert record["error"] is None and record["goal_reached"] is None  # inner_maze has no goal
    assert 0.0 < record["time_to_localized"] < 8.0 and record["localization_error"] < 0.05
    assert record["localization_rms"] <= record["localization_error_max"]
    label, parameters = configs.resolve("plan_follow", "default")
    record = run_episode(
        EpisodeSpec("plan_follow", label, parameters, {"file": "open_room.yaml"}, seed=0, duration=30.0)
    )
    assert record["error"] is None and record["goal_reached"] is True and record["plans"] >= 1
    assert record["cross_track"] < 0.03 and record["time_to_goal"] < 30.0


def test_a_plan_follow_episode_plans_with_the_planner_nodes_class_and_its_parameters():
    """The planner parameters an episode carries are the planner node's (amr_planning.planner.Planner): the roadmap
    given instead of A* plans another way to the same goal (before, only `resolution` was read)."""
    label, parameters = configs.resolve("plan_follow", "default")
    spec = EpisodeSpec("plan_follow", label, parameters, {"file": "open_room.yaml"}, seed=0, duration=30.0)
    grid = run_episode(spec)
    roadmap = run_episode(
        dataclasses.replace(spec, parameters={**parameters, "planner": {**parameters["planner"], "planner": "prm"}})
    )
    assert grid["error"] is None and roadmap["error"] is None
    assert grid["goal_reached"] is roadmap["goal_reached"] is True
    assert abs(grid["distance"] - roadmap["distance"]) > 0.01, (grid["distance"], roadmap["distance"])


def test_a_localization_episode_in_a_room_one_feature_breaks_records_when_the_feature_was_seen():
    from amr_maps.symmetry_families import symmetry_case

    case = symmetry_case("notch", 1)  # the notch comes into view at about 13 s, the filter declares a few s later
    label, parameters = configs.resolve("localization", "default")
    record = run_episode(
        EpisodeSpec(
            "localization",
            label,
            parameters,
            {"data": case.world, "name": "notch_1"},
            seed=1,
            lidar_noise=0.02,
            encoder_noise=0.02,
            slip=0.02,
            duration=60.0,
            options={"symmetric": case.symmetric, "stop_after": 1.0},
        )
    )
    assert record["error"] is None, record["extra"]
    extra = record["extra"]
    assert 0.0 < extra["feature_glimpsed"] <= extra["feature_seen"] < 60.0
    assert record["time_to_localized"] is not None and record["localization_error"] <= 0.10
    assert record["time"] <= record["time_to_localized"] + 1.0 + 0.1, "stop_after ends the run"


def test_a_navigation_episode_takes_a_saved_map_as_the_stack_takes_map_and_names_a_missing_one(tmp_path):
    """Option `map` (the stack's `map:=`: a map saved by maze_mapping, in the world's frame): the filter and the
    planner take that file, the simulator runs the world; a path that is not a map is named in the record."""
    world = build_world({"file": "pillar_goal.yaml"})
    grid = rasterize_world(world, 0.03)  # not the stack's 0.02: the file's cells, not the world's, are served
    saved = save_map(grid, tmp_path / "saved")
    label, parameters = configs.resolve("navigation", "default")
    spec = EpisodeSpec(
        "navigation",
        label,
        parameters,
        {"file": "pillar_goal.yaml"},
        seed=0,
        duration=40.0,
        options={"map": str(saved)},
    )
    served, loaded = stack_map(spec, world), load_map(saved)
    assert served.resolution == pytest.approx(0.03) and served.origin == pytest.approx(loaded.origin)
    np.testing.assert_array_equal(served.data, loaded.data)
    record = run_episode(spec)
    assert record["error"] is None
    assert record["goal_reached"] is True and record["collisions"] == 0
    missing = run_episode(dataclasses.replace(spec, options={"map": str(tmp_path / "none.yaml")}))
    assert "none.yaml" in missing["error"]
