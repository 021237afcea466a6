"""Following a fleet plan at the robots' own speeds (amr_planning.fleet_execution): the action dependencies
executed at random speeds never put two robots on one vertex (and without them they do), and the execution time
waits for the dependencies, not for steps."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.fleet_plans import corridor_with_pocket, execute, graph_of, maze_case

from amr_planning.fleet_execution import execution_time
from amr_planning.fleet_improve import improve
from amr_planning.fleet_lacam import plan_lacam
from amr_planning.fleet_lattice import lattice
from amr_planning.fleet_paths import FleetPlan


@pytest.mark.parametrize("seed", [0, 1])
def test_robots_following_the_dependencies_at_random_speeds_never_meet_and_all_arrive(seed):
    data, costmap, pitch = maze_case(seed)
    graph = lattice(costmap, pitch)
    starts = [graph.nearest(*robot["start"][:2]) for robot in data["robots"]]
    goals = [graph.nearest(*robot["goal"][:2]) for robot in data["robots"]]
    plan = improve(plan_lacam(graph, starts, goals))
    for trial in range(3):
        execute(plan, np.random.default_rng(trial))


def test_without_the_dependencies_random_speeds_make_robots_meet():
    """The check above can fail: the same execution with no dependencies puts two robots on one vertex."""
    graph = corridor_with_pocket()
    plan = plan_lacam(graph, [0, 4], [4, 0])
    none = [[[] for _ in path] for path in plan.paths]
    with pytest.raises(AssertionError, match="both on vertex|may enter"):
        for trial in range(20):
            execute(plan, np.random.default_rng(trial), none)


def test_execution_time_waits_for_the_dependencies_not_for_steps_and_counts_the_turns():
    # 0-1-2-3 in a row 1 m apart, 4 above 3; r0 drives 1 -> 2 -> 3, turns a quarter and drives to 4; r1 follows it
    # 0 -> 1 -> 2, each move once r0 has left the vertex. At 0.5 m/s (2 s a move) and 1 rad/s:
    # r0 arrives at 2 s, 4 s, 6 s + pi/2; r1 enters 1 at max(0, 2) + 2 = 4 s and 2 at max(4, 4) + 2 = 6 s.
    graph = graph_of([[0, 0], [1, 0], [2, 0], [3, 0], [3, 1]], [(0, 1), (1, 2), (2, 3), (3, 4)])
    plan = FleetPlan(graph, ((1, 2, 3, 4), (0, 1, 2, 2)), 0)
    assert plan.makespan == 3
    assert execution_time(plan, 0.5, 1.0) == pytest.approx(6.0 + math.pi / 2)
    assert execution_time(plan, 0.5, 100.0) == pytest.approx(6.0 + math.pi / 200)
    # r1 planned to wait a step first: more lockstep steps, the same time (it waits for r0's moves, not for steps)
    waiting = FleetPlan(graph, ((1, 2, 3, 4), (0, 0, 1, 2)), 0)
    assert waiting.makespan == 3 and execution_time(waiting, 0.5, 1.0) == pytest.approx(6.0 + math.pi / 2)
    # r1 alone would be done at 4 s: the 2 s more are r0's
    assert execution_time(FleetPlan(graph, ((0, 1, 2),), 0), 0.5, 1.0) == pytest.approx(4.0)
    for speed, turn_rate in [(0.0, 1.0), (math.nan, 1.0), (0.5, -1.0), (0.5, math.inf)]:
        with pytest.raises(ValueError, match="speed and turn_rate"):
            execution_time(plan, speed, turn_rate)
