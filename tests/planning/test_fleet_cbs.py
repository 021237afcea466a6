"""Conflict-based search (amr_planning.fleet_cbs), the least-cost reference, beside LaCAM on the same small
requests: both plan a swap through a pocket (CBS at least cost), both refuse bad requests naming what is wrong."""

from __future__ import annotations

import pytest
from support.fleet_plans import check, corridor_with_pocket

from amr_planning.errors import PlanningError
from amr_planning.fleet_cbs import plan_together
from amr_planning.fleet_lacam import plan_lacam


@pytest.mark.parametrize("solver", [plan_together, plan_lacam])
def test_two_robots_swap_ends_of_a_corridor_through_its_pocket(solver):
    graph = corridor_with_pocket()
    plan = solver(graph, [0, 4], [4, 0])
    check(plan, [0, 4], [4, 0])
    assert 5 in plan.paths[0] or 5 in plan.paths[1]  # one of them waited in the pocket
    if solver is plan_together:  # least sum of steps: 4 + 4 moves, one detour of 2 and one wait, or the like
        assert plan.cost == 11


@pytest.mark.parametrize(
    "starts, goals, message",
    [
        ([0, 0], [3, 4], "share a start"),
        ([0, 1], [4, 4], "share a goal"),
        ([0, 9], [3, 4], "not on the lattice"),
        ([0], [3, 4], "1 starts but 2 goals"),
    ],
)
def test_bad_requests_are_refused_with_what_is_wrong(starts, goals, message):
    for solver in (plan_together, plan_lacam):
        with pytest.raises(PlanningError, match=message):
            solver(corridor_with_pocket(), starts, goals)
