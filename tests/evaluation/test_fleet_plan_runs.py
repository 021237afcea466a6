"""The fleet driven by one plan (amr_navigation.fleet_schedule) in whole runs of the simulator's fleet
(amr_evaluation.fleet_navigation.run_fleet with coordination "plan"): two robots pass each other through a pocket,
robots with particle filters localize first and then follow their plan. The schedule itself:
tests/navigation/test_fleet_schedule.py."""

from __future__ import annotations

import math

import pytest

from amr_evaluation import configs
from amr_evaluation.fleet_navigation import run_fleet
from amr_maps.world import world_from_dict
from amr_navigation.fleet_planner_config import FleetPlannerConfig


def corridor() -> object:
    """A corridor one robot wide (0.35 m free) from -2 to 2 along x, a side pocket at x = 0.8; r1 and r2 face
    each other from its two ends, each sent to the other's end."""
    walls = [
        [-2.0, -0.2, 2.0, -0.2],
        [-2.0, 0.2, 0.6, 0.2],
        [1.0, 0.2, 2.0, 0.2],
        [0.6, 0.2, 0.6, 0.7],
        [1.0, 0.2, 1.0, 0.7],
        [0.6, 0.7, 1.0, 0.7],
        [-2.0, -0.2, -2.0, 0.2],
        [2.0, -0.2, 2.0, 0.2],
    ]
    return world_from_dict(
        {
            "name": "corridor",
            "wall_thickness": 0.05,
            "walls": walls,
            "robots": [
                {"name": "r1", "start": [-1.6, 0.0, 0.0], "goal": [1.6, 0.0, 0.1]},
                {"name": "r2", "start": [1.6, 0.0, math.pi], "goal": [-1.6, 0.0, 0.1]},
            ],
        }
    )


def test_two_robots_planned_together_pass_each_other_through_the_pocket():
    run = run_fleet(corridor(), localization="truth", duration=150.0, seed=2, coordination="plan", lattice_spacing=0.4)
    assert run.reached == 2, [robot.events for robot in run.robots]
    assert run.robot_contacts == 0 and run.wall_contacts == 0


def test_the_library_fleet_makes_its_coordinator_as_the_fleet_planner_node_does(monkeypatch):
    """One place makes the coordinator from the fleet planner's parameters (FleetPlannerConfig.coordinator): the
    library fleet takes the node's defaults (routes that expire after route_lifetime, renewed) and what it is given;
    before, it made its own with routes that never expired."""
    made = []
    original = FleetPlannerConfig.coordinator

    def recording(self, names, priorities=None):
        made.append(self)
        return original(self, names, priorities)

    monkeypatch.setattr(FleetPlannerConfig, "coordinator", recording)
    parameters = {**configs.resolve("fleet_navigation", "default")[1], "fleet_planner": {"stuck_time": 12.0}}
    run_fleet(corridor(), parameters, localization="truth", duration=0.2, coordination="plan", lattice_spacing=0.4)
    assert len(made) == 1
    config = made[0]
    assert (config.robots, config.lattice_spacing, config.stuck_time) == (["r1", "r2"], 0.4, 12.0)
    assert config.route_lifetime == FleetPlannerConfig.from_params({"robots": ["r"]}).route_lifetime == 30.0  # expire


def test_a_coordination_other_than_rules_or_plan_is_refused():
    with pytest.raises(ValueError, match="coordination 'central'"):
        run_fleet(corridor(), localization="truth", duration=1.0, coordination="central")


def test_with_particle_filters_the_fleet_localizes_first_then_follows_its_plan():
    """The robots go by the traffic rules (explore until localized, then to their goals) until every navigator is
    confident at once; the fleet is then planned from the estimates. A generated tree maze, three robots each sent
    to the next one's start (2.5 m across: its 94 s of driving at 4 m cost 40 s of CPU)."""
    from amr_maps.maze_families import generate, grid_pitch
    from amr_planning.fleet_starts import with_robots

    data = with_robots(generate("perfect", 4, size=2.5), 3, 4)
    run = run_fleet(
        world_from_dict(data), seed=4, duration=200.0, coordination="plan", lattice_spacing=grid_pitch(data)
    )
    events = [event for robot in run.robots for event in robot.events]
    assert any("fleet plan 1" in event for event in events), events
    assert run.reached == 3, events
    assert run.robot_contacts == 0 and run.wall_contacts == 0
    assert run.false_localized == 0
