"""Fleet replans that hold no one but those concerned, plans made off the caller's thread, routes that expire
(amr_navigation.fleet_coordinator), and the fleet file's roster and priorities (amr_navigation.fleet_file)."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from support.fleet_costmaps import ring_costmap

from amr_maps.world import WorldError
from amr_navigation.fleet_coordinator import FOLLOW, HOLD, FleetCoordinator, compute_plan
from amr_navigation.fleet_file import FleetFileError, load_fleet
from amr_planning.fleet_cbs import first_conflict

GOALS = {"r1": (1.0, 1.0), "r2": (-1.0, 1.0), "r3": (1.0, -1.0)}
STARTS = {"r1": (-1.0, -1.0), "r2": (1.0, 1.0), "r3": (-1.0, 1.0)}


def planned_on_the_ring(**options) -> FleetCoordinator:
    coordinator = FleetCoordinator(list(GOALS), 0.4, **options)
    coordinator.set_costmap(ring_costmap())
    for name, (x, y) in STARTS.items():
        coordinator.observe(name, 0.0, x, y, True, GOALS[name])
    routes = coordinator.plan()
    assert {route.state for route in routes.values()} == {FOLLOW}
    return coordinator


def test_a_jumped_robot_is_planned_again_alone_while_the_others_keep_their_routes_and_drive_on():
    coordinator = planned_on_the_ring()
    before = {robot: coordinator.schedule.waypoints[robot].copy() for robot in (0, 2)}  # r1, r3: all of their ways
    x, y = STARTS["r2"]
    assert coordinator.observe("r2", 0.1, x - 0.8, y, True, GOALS["r2"]) == {}  # 0.8 m in 0.1 s: jumped
    assert coordinator.schedule is not None and coordinator.plan_due()  # the plan stays in force meanwhile
    job, holds = coordinator.begin_plan()
    assert set(holds) == {"r2"} and holds["r2"].state == HOLD  # only r2 is held
    assert job.replan == frozenset({1})
    outcome = compute_plan(job)
    routes = coordinator.finish_plan(outcome)
    assert outcome.partial and coordinator.partial_plans == 1 and coordinator.plans == 2
    assert {route.state for route in routes.values()} == {FOLLOW}
    for robot in (0, 2):  # r1 and r3 go the same ways as before the replan
        assert np.allclose(coordinator.schedule.waypoints[robot], before[robot])
    assert first_conflict([list(path) for path in coordinator.schedule.plan.paths]) is None
    start = coordinator.schedule.plan.graph.points[coordinator.schedule.plan.vertices(1)[0]]
    assert np.hypot(start[0] - (x - 0.8), start[1] - y) < 0.4  # r2 planned from where it stands now


def test_a_plan_made_on_another_thread_is_adopted_unless_dropped_meanwhile():
    coordinator = planned_on_the_ring(partial=False)
    x, y = STARTS["r2"]
    coordinator.observe("r2", 0.1, x - 0.8, y, True, GOALS["r2"])  # jumped: the whole fleet planned again
    job, holds = coordinator.begin_plan()
    assert set(holds) == set(GOALS) and not coordinator.plan_due()  # one plan at a time
    result = {}
    worker = threading.Thread(target=lambda: result.update(outcome=compute_plan(job)))
    worker.start()
    coordinator.observe("r1", 0.15, -1.0, -1.0, True, GOALS["r1"])  # statuses are read meanwhile
    worker.join(30.0)
    routes = coordinator.finish_plan(result["outcome"])
    assert set(routes) == set(GOALS) and coordinator.plans == 2
    # a plan begun before the goal changed is not adopted
    coordinator.observe("r2", 0.2, x - 0.8, y, True, (-1.0, -0.2))
    job, _ = coordinator.begin_plan()
    coordinator.observe("r3", 0.25, -1.0, 1.0, True, (0.2, 1.0))  # dropped meanwhile
    assert coordinator.finish_plan(compute_plan(job)) == {} and coordinator.plans == 2


def test_routes_expire_unless_renewed_and_a_hold_is_never_renewed():
    coordinator = planned_on_the_ring(route_lifetime=10.0)
    route = coordinator.route("r1")
    assert route.expires == pytest.approx(10.0)
    assert coordinator.renewals() == {}  # not yet halfway
    for stamp in (4.0, 6.0):
        for name, (x, y) in STARTS.items():
            coordinator.observe(name, stamp, x, y, True, GOALS[name])
    renewed = coordinator.renewals()
    assert set(renewed) == set(GOALS) and all(r.expires == pytest.approx(16.0) for r in renewed.values())
    assert np.allclose(renewed["r1"].waypoints, route.waypoints)
    coordinator.observe("r2", 6.05, 0.2, 1.0, True, GOALS["r2"])  # jumped
    _, holds = coordinator.begin_plan()
    assert holds["r2"].expires == pytest.approx(16.05)
    for name, (x, y) in STARTS.items():
        coordinator.observe(name, 20.0, x, y, True, GOALS[name])
    assert "r2" not in coordinator.renewals()  # held: its hold runs out, and it plans by itself


FLEET = """
name: two
wall_thickness: 0.05
walls: [[-2, -1, 2, -1], [2, -1, 2, 1], [2, 1, -2, 1], [-2, 1, -2, -1]]
robots:
  - {name: r1, start: [-1.5, 0, 0], goal: [1.5, 0, 0.15]%s}
  - {name: r2, start: [1.5, 0, 3.14], goal: [-1.5, 0, 0.15]%s}
"""


def test_the_fleet_file_gives_the_roster_and_priorities(tmp_path):
    path = tmp_path / "two.yaml"
    path.write_text(FLEET % (", priority: 1", ", priority: 0"))
    fleet = load_fleet(path)
    assert fleet.names == ["r1", "r2"] and fleet.priorities == [1, 0]
    assert fleet.in_priority_order() == ["r2", "r1"]
    path.write_text(FLEET % ("", ""))
    assert load_fleet(path).priorities == [0, 1]  # the list's order


@pytest.mark.parametrize(
    ("first", "second", "message"),
    [
        (", priority: -1", "", "robots[0].priority: must be 0 or more, got -1"),
        (", priority: high", "", "robots[0].priority: must be an integer, 0 or more, got 'high'"),
        (", priority: 1.5", "", "robots[0].priority: must be an integer, 0 or more, got 1.5"),
        (", priority: true", "", "robots[0].priority: must be an integer, 0 or more, got True"),
        (", priority: 3", ", priority: 3", "robots[1].priority: 3 is already the priority of robots[0] (r1)"),
    ],
)
def test_a_bad_fleet_file_is_refused_naming_file_key_and_value(tmp_path, first, second, message):
    path = tmp_path / "two.yaml"
    path.write_text(FLEET % (first, second))
    with pytest.raises(FleetFileError) as error:
        load_fleet(path)
    assert str(error.value) == f"{path}: {message}"


def test_a_fleet_file_without_robots_or_with_an_unknown_key_is_refused(tmp_path):
    path = tmp_path / "one.yaml"
    path.write_text("name: one\nwall_thickness: 0.05\nwalls: [[-2, -1, 2, -1], [-2, 1, 2, 1]]\nstart: [0, 0, 0]\n")
    with pytest.raises(FleetFileError, match="robots: the world has no robots list"):
        load_fleet(path)
    path.write_text(FLEET % (", rank: 2", ""))
    with pytest.raises(WorldError, match=r"robots\[0\].rank: unknown key"):
        load_fleet(path)
