"""The traffic rules (amr_navigation.traffic) in whole runs of the simulator's fleet (amr_evaluation.fleet_navigation):
a box that is not on the map (stop, wait, replan around it), two robots face to face in a corridor one robot wide
(right of way), a robot parked in a dead end, a place aside found farther away, a convoy. The rules themselves:
tests/navigation/test_traffic.py."""

from __future__ import annotations

import math

import pytest

from amr_evaluation.fleet_navigation import run_fleet
from amr_maps.world import world_from_dict


def test_a_box_not_on_the_map_stops_the_robot_which_replans_around_it():
    walls = [[-1.5, -0.75, 1.5, -0.75], [1.5, -0.75, 1.5, 0.75], [1.5, 0.75, -1.5, 0.75], [-1.5, 0.75, -1.5, -0.75]]
    robots = [{"name": "r1", "start": [-1.1, 0.0, 0.0], "goal": [1.1, 0.0, 0.1]}]
    known = world_from_dict({"name": "room", "wall_thickness": 0.05, "walls": walls, "robots": robots})
    real = world_from_dict(
        {
            "name": "room_box",
            "wall_thickness": 0.05,
            "walls": walls,
            "robots": robots,
            "boxes": [[-0.1, -0.15, 0.1, 0.15]],
        }
    )
    run = run_fleet(real, map_world=known, localization="truth", duration=60.0, seed=1)
    robot = run.robots[0]
    assert robot.reached, robot.events
    assert robot.wall_collisions == 0  # the box is a solid: touching it is a wall collision
    assert robot.stops >= 1 and robot.replans_around >= 1, robot.events


def corridor(pocket_x: float, junction: bool = False, length: float = 2.0):
    """A corridor one robot wide (0.35 m free) from -length to length along x, with a side pocket (0.35 m wide,
    0.475 m deep) or, with junction, a side corridor leading on at pocket_x; r1 and r2 face each other."""
    side = 0.7 if not junction else 1.2
    walls = [
        [-length, -0.2, length, -0.2],
        [-length, 0.2, pocket_x - 0.2, 0.2],
        [pocket_x + 0.2, 0.2, length, 0.2],
        [pocket_x - 0.2, 0.2, pocket_x - 0.2, side],
        [pocket_x + 0.2, 0.2, pocket_x + 0.2, side],
        [-length, -0.2, -length, 0.2],
        [length, -0.2, length, 0.2],
    ]
    if junction:  # the side corridor turns and ends in a room
        walls += [
            [pocket_x - 0.2, side, pocket_x - 0.6, side],
            [pocket_x + 0.2, side, pocket_x + 0.2, side + 0.6],
            [pocket_x - 0.6, side, pocket_x - 0.6, side + 0.6],
            [pocket_x - 0.6, side + 0.6, pocket_x + 0.2, side + 0.6],
        ]
    else:
        walls.append([pocket_x - 0.2, side, pocket_x + 0.2, side])
    return world_from_dict(
        {
            "name": "corridor",
            "wall_thickness": 0.05,
            "walls": walls,
            "robots": [
                {"name": "r1", "start": [-length + 0.3, 0.0, 0.0], "goal": [length - 0.3, 0.0, 0.1]},
                {"name": "r2", "start": [length - 0.3, 0.0, math.pi], "goal": [-length + 0.3, 0.0, 0.1]},
            ],
        }
    )


@pytest.mark.parametrize("pocket_x, junction", [(0.8, False), (-0.8, False), (0.9, True), (-0.5, True)])
def test_two_robots_face_to_face_in_a_one_wide_corridor_both_reach_their_goals(pocket_x, junction):
    run = run_fleet(corridor(pocket_x, junction), localization="truth", duration=150.0, seed=2)
    events = {robot.name: robot.events for robot in run.robots}
    assert run.reached == 2, events
    assert run.robot_contacts == 0 and run.wall_contacts == 0, events
    r1, r2 = run.robots
    # the rule: r2 (second in the list) gives way where it can; where it cannot (the place to wait lies on r1's
    # side), it says so and r1 gives way
    if pocket_x > 0:
        assert r2.yields >= 1 and r1.yields == 0, events
    else:
        assert r2.cannot_yield >= 1 and r1.yields >= 1, events


def test_without_the_rules_the_corridor_deadlocks():
    run = run_fleet(corridor(0.8), localization="truth", duration=60.0, seed=2, use_traffic=False)
    assert run.reached < 2 or run.robot_contacts > 0


def dead_end(parked_first: bool):
    """A corridor one robot wide (0.35 m free) closed at x = -2, with a side pocket (0.35 m wide, 0.65 m deep)
    at x = 0.8 and open on to x = 2. One robot is parked at its goal at x = -0.6 (it starts there); the other
    comes from x = 1.7 to a goal at x = -1.6, deeper in the dead end: it must pass the parked robot, which has no
    place aside but out past it."""
    walls = [
        [-2.0, -0.2, 2.0, -0.2],
        [-2.0, 0.2, 0.6, 0.2],
        [1.0, 0.2, 2.0, 0.2],
        [0.6, 0.2, 0.6, 0.9],
        [1.0, 0.2, 1.0, 0.9],
        [0.6, 0.9, 1.0, 0.9],
        [-2.0, -0.2, -2.0, 0.2],
        [2.0, -0.2, 2.0, 0.2],
    ]
    parked = {"name": "parked", "start": [-0.6, 0.0, 0.0], "goal": [-0.6, 0.0, 0.1]}
    mover = {"name": "mover", "start": [1.7, 0.0, math.pi], "goal": [-1.6, 0.0, 0.1]}
    return world_from_dict(
        {
            "name": "dead_end",
            "wall_thickness": 0.05,
            "walls": walls,
            "robots": [parked, mover] if parked_first else [mover, parked],
        }
    )


@pytest.mark.parametrize("parked_first", [True, False])
def test_a_robot_parked_in_a_dead_end_comes_out_past_the_robot_that_must_pass_it(parked_first):
    run = run_fleet(dead_end(parked_first), localization="truth", duration=150.0, seed=3)
    robots = {robot.name: robot for robot in run.robots}
    events = {robot.name: robot.events for robot in run.robots}
    assert run.reached == 2, events
    assert run.robot_contacts == 0 and run.wall_contacts == 0, events
    # the way-out rule: the parked robot, boxed in, went aside past the mover, which made way for it first
    assert any("boxed in" in event for event in robots["parked"].events), events
    assert robots["mover"].yields >= 1 and robots["parked"].yields >= 1, events


def far_pocket():
    """A corridor one robot wide (0.35 m free) from x = -2 to x = 7, closed at both ends, with one side pocket
    (0.35 m wide, 0.65 m deep) at x = 6. r1 (first in the list) goes from x = -1.2 to the right end, r2 from
    x = 1.2 to the left end: they meet near x = 0. Neither has a place aside within yield_search (4 m) of steps:
    r1's side is the dead end holding r2's goal; r2's only place is the pocket, about 5 m back."""
    walls = [
        [-2.0, -0.2, 7.0, -0.2],
        [-2.0, 0.2, 5.8, 0.2],
        [6.2, 0.2, 7.0, 0.2],
        [5.8, 0.2, 5.8, 0.9],
        [6.2, 0.2, 6.2, 0.9],
        [5.8, 0.9, 6.2, 0.9],
        [-2.0, -0.2, -2.0, 0.2],
        [7.0, -0.2, 7.0, 0.2],
    ]
    return world_from_dict(
        {
            "name": "far_pocket",
            "wall_thickness": 0.05,
            "walls": walls,
            "robots": [
                {"name": "r1", "start": [-1.2, 0.0, 0.0], "goal": [6.7, 0.0, 0.1]},
                {"name": "r2", "start": [1.2, 0.0, math.pi], "goal": [-1.7, 0.0, 0.1]},
            ],
        }
    )


def test_when_neither_robot_can_give_way_nearby_the_lower_priority_one_searches_farther():
    run = run_fleet(far_pocket(), localization="truth", duration=300.0, seed=4)
    robots = {robot.name: robot for robot in run.robots}
    events = {robot.name: robot.events for robot in run.robots}
    assert run.reached == 2, events
    assert run.robot_contacts == 0 and run.wall_contacts == 0, events
    # rule 5: both said they cannot give way within reach; r2 (second in the list) then went to the far pocket
    assert robots["r1"].cannot_yield >= 1 and robots["r2"].cannot_yield >= 1, events
    assert any("searched farther" in event for event in robots["r2"].events), events
    assert robots["r1"].yields == 0, events


def convoy():
    """A corridor one robot wide (0.35 m free) from x = -1 to x = 5, closed at x = 5, opening at x = -1 into a
    room (1.5 x 1.6 m). r2 and r3 go right, r3 0.8 m behind r2, to goals near the closed end; r1 (first in the
    list) comes from the closed end to a goal in the room. r1 and r2 meet face to face: r2's only place aside
    is the room, behind r3, which waits behind r2; r1's side is the dead end holding the others' goals."""
    walls = [
        [-1.0, -0.2, 5.0, -0.2],
        [-1.0, 0.2, 5.0, 0.2],
        [5.0, -0.2, 5.0, 0.2],
        [-1.0, 0.2, -1.0, 0.8],
        [-1.0, -0.2, -1.0, -0.8],
        [-1.0, 0.8, -2.5, 0.8],
        [-1.0, -0.8, -2.5, -0.8],
        [-2.5, -0.8, -2.5, 0.8],
    ]
    return world_from_dict(
        {
            "name": "convoy",
            "wall_thickness": 0.05,
            "walls": walls,
            "robots": [
                {"name": "r1", "start": [4.3, 0.0, math.pi], "goal": [-2.1, 0.45, 0.1]},
                {"name": "r2", "start": [1.2, 0.0, 0.0], "goal": [4.7, 0.0, 0.1]},
                {"name": "r3", "start": [0.4, 0.0, 0.0], "goal": [3.9, 0.0, 0.1]},
            ],
        }
    )


def test_a_robot_behind_the_one_that_must_give_way_makes_room_for_it_first():
    """Rule 6: r2 must give way to r1 but its way to the room is where r3 stands (r3 waits for r2, it gives way to
    no one): r2 goes aside past r3, holds before it, and r3 makes way first. Without it the three stand for
    good (every search for a place treats r3 as a wall; planning around fails in the corridor)."""
    run = run_fleet(convoy(), localization="truth", duration=300.0, seed=5)
    robots = {robot.name: robot for robot in run.robots}
    events = {robot.name: robot.events for robot in run.robots}
    assert run.reached == 3, events
    assert run.robot_contacts == 0 and run.wall_contacts == 0, events
    assert any("past r3 (they make way first)" in event for event in robots["r2"].events), events
    assert robots["r3"].yields >= 1, events
