"""The fleet episode (amr_evaluation.fleet_navigation): robots placed on a generated world, each sent to the next
one's start, every one driven by its own navigation loop with the traffic rules, in lockstep on the Fleet."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_evaluation import configs
from amr_evaluation.episode import EpisodeSpec, run_episode
from amr_evaluation.fleet_navigation import run_fleet
from amr_maps.maze_families import generate
from amr_maps.world import world_from_dict
from amr_planning.fleet_starts import MIN_SEPARATION, START_CLEARANCE, with_robots


def test_with_robots_spreads_the_starts_and_sends_each_robot_to_the_next_start():
    data = with_robots(generate("perfect", 3, size=4.0), 5, seed=7)
    world = world_from_dict(data)
    starts = np.array([[r.start.x, r.start.y] for r in world.fleet])
    goals = np.array([[r.goal.x, r.goal.y] for r in world.fleet])
    assert [r.name for r in world.fleet] == ["r1", "r2", "r3", "r4", "r5"]
    gaps = np.hypot(starts[:, None, 0] - starts[None, :, 0], starts[:, None, 1] - starts[None, :, 1])
    assert gaps[~np.eye(5, dtype=bool)].min() >= MIN_SEPARATION
    assert world.clearance(starts).min() >= START_CLEARANCE - 0.03  # the costmap's clearance is conservative
    assert np.allclose(goals, np.roll(starts, -1, axis=0))
    assert with_robots(generate("perfect", 3, size=4.0), 5, seed=7) == data  # a pure function of its inputs
    with pytest.raises(ValueError, match="no room for 40 robots"):
        with_robots(generate("perfect", 3, size=3.0), 40, seed=7)


@pytest.mark.parametrize("seed", [0, 1, 3])
def test_with_robots_places_no_robot_in_a_closed_pocket(seed):
    """`dead_ends` mazes draw walled cells a robot fits in but cannot leave: every start, and so every goal,
    must be one the planner reaches from every other start."""
    from amr_maps.rasterize import rasterize_world
    from amr_planning.planner import Planner, PlannerConfig

    data = with_robots(generate("dead_ends", seed, size=4.0), 6, seed)
    world = world_from_dict(data)
    config = PlannerConfig.from_params({**configs.resolve("navigation", "default")[1]["planner"], "world": ""})
    planner = Planner(rasterize_world(world, config.resolution), config)
    for spec in world.fleet:
        path = planner.plan((spec.start.x, spec.start.y), (spec.goal.x, spec.goal.y))
        assert math.hypot(*(path[-1] - (spec.goal.x, spec.goal.y))) < 0.05, spec.name


def test_run_fleet_refuses_a_robot_without_a_goal():
    data = with_robots(generate("pillars", 1, size=3.0), 2, seed=1)
    del data["robots"][1]["goal"]
    with pytest.raises(ValueError, match="robots without a goal: r2"):
        run_fleet(world_from_dict(data), localization="truth")


def test_fleet_episode_in_a_generated_room_every_robot_reaches_its_goal_without_contact():
    label, parameters = configs.resolve("fleet_navigation", "default")
    spec = EpisodeSpec(
        "fleet_navigation",
        label,
        parameters,
        {"family": "pillars", "seed": 1, "options": {"size": 3.0}},
        seed=1,
        duration=120.0,
        options={"robots": 3, "localization": "truth"},
    )
    record = run_episode(spec)
    assert record["error"] is None, record["extra"]
    assert record["goal_reached"] is True and record["collisions"] == 0, record["extra"]
    assert record["extra"]["robots"] == 3 and record["extra"]["robot_contacts"] == 0
    assert math.isfinite(record["time"]) and record["time"] < 120.0
    assert [robot["name"] for robot in record["extra"]["per_robot"]] == ["r1", "r2", "r3"]


def test_a_robot_run_counts_withdrawals_and_the_time_unsure_after_the_first_declaration():
    from amr_evaluation.fleet_navigation import RobotRun

    run = RobotRun("r1")
    dt = 0.05
    said = [False] * 20 + [True] * 10 + [False] * 30 + [True] * 5 + [False] * 4  # unsure before: not counted
    for step, localized in enumerate(said):
        run.note_localized(step * dt, localized, dt)
    assert run.first_localized == 20 * dt
    assert run.withdrawals == 2
    assert math.isclose(run.unsure_time, 34 * dt)
    assert math.isclose(run.longest_unsure, 30 * dt)
    never = RobotRun("r2")
    for step in range(10):
        never.note_localized(step * dt, False, dt)
    assert (never.first_localized, never.withdrawals, never.unsure_time) == (None, 0, 0.0)
