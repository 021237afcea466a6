"""Maze families: every family loads, starts free, is reproducible per seed, and judges reachability right."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_maps.maze_families import FAMILIES, WALK_BUDGET, MazeError, generate, goal_reachable, walk_length
from amr_maps.world import world_from_dict
from amr_simulation.physics import Physics

RADIUS = 0.105  # TurtleBot3 Burger footprint
SEEDS = (0, 1, 2)


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("seed", SEEDS)
def test_every_family_loads_with_a_free_start_and_a_reachable_goal(family, seed):
    data = generate(family, seed)
    world = world_from_dict(data)
    physics = Physics(world.polygons, RADIUS)
    assert physics.clearance(world.start.x, world.start.y) >= RADIUS, "the robot starts inside a wall"
    assert world.goal is not None
    assert physics.clearance(world.goal.x, world.goal.y) > 0.0, "the goal centre is inside a wall"
    assert math.hypot(world.goal.x - world.start.x, world.goal.y - world.start.y) > world.goal.radius
    assert goal_reachable(data, "right") is True
    assert walk_length(data, "right") <= WALK_BUDGET, "the goal is beyond the follower's time budget"


def test_a_layout_without_a_reachable_goal_is_drawn_again():
    # dead_ends seed 128's first layout has no goal within the follower's walk budget (every dead end is walked)
    data = generate("dead_ends", 128)
    assert goal_reachable(data, "right") is True
    assert walk_length(data, "right") <= WALK_BUDGET
    assert generate("dead_ends", 128) == data, "the draws again come from the seed's own stream"


@pytest.mark.parametrize("family", FAMILIES)
def test_same_seed_same_world_other_seed_other_world(family):
    assert generate(family, 7) == generate(family, 7)
    assert generate(family, 7) != generate(family, 8)


@pytest.mark.parametrize("family", ["perfect", "loops", "bends", "open_room"])
def test_left_hand_goals_are_reachable_by_a_left_hand_follower(family):
    data = generate(family, 3, hand="left")
    assert goal_reachable(data, "left") is True
    assert walk_length(data, "left") <= WALK_BUDGET


def test_options_fix_what_they_name():
    data = generate("perfect", 0, size=4.0, width=0.5, thickness=0.05)
    xs = [v for wall in data["walls"] for v in wall[0::2]]
    assert data["wall_thickness"] == 0.05
    assert max(xs) - min(xs) == pytest.approx(7 * 0.55)  # 4 m holds 7 cells of pitch 0.55


@pytest.mark.parametrize("bend_deg", [45.0, 60.0, 150.0])
def test_bends_turn_by_the_angle_asked(bend_deg):
    data = generate("bends", 0, bend_deg=bend_deg, bends=3, width=0.4)
    walls = np.array(data["walls"])
    headings = np.degrees(np.arctan2(walls[:, 3] - walls[:, 1], walls[:, 2] - walls[:, 0]))
    # the mitred inner walls meet at the bend angle: some pair of walls differs by it (mod 180)
    differences = np.abs((headings[:, None] - headings[None, :] + 90.0) % 180.0 - 90.0)
    assert np.any(np.abs(differences - min(bend_deg, 180.0 - bend_deg)) < 0.5)


def test_rotated_mazes_are_turned_by_the_angle_asked():
    data = generate("rotated", 0, angle=math.radians(30.0), loop_fraction=0.0)
    walls = np.array(data["walls"])
    headings = np.degrees(np.arctan2(walls[:, 3] - walls[:, 1], walls[:, 2] - walls[:, 0])) % 90.0
    assert np.allclose(headings, 30.0, atol=1e-3)


def test_narrowing_corridors_taper_to_the_width_asked():
    data = generate("narrowing", 0, max_width=0.6, min_width=0.3, thickness=0.02)
    world = world_from_dict(data)
    physics = Physics(world.polygons, 1.0)
    # the goal sits on the centre line 0.3 m before the narrow end: walls 0.15 m away (less half
    # their 0.02 m thickness, plus what the taper has not yet closed over the last 0.3 m)
    assert physics.clearance(world.goal.x, world.goal.y) == pytest.approx(0.145, abs=0.01)


def island_world(goal: list[float]) -> dict:
    """A 4 x 4 m room with a 1 m square island in the middle; the start hugs the outer wall."""
    return {
        "wall_thickness": 0.05,
        "walls": [[-2, -2, 2, -2], [2, -2, 2, 2], [2, 2, -2, 2], [-2, 2, -2, -2]],
        "boxes": [[-0.5, -0.5, 0.5, 0.5]],
        "start": [0.0, -1.8, 0.0],  # heading +x with the outer wall on the right
        "goal": goal,
    }


def test_a_goal_by_an_island_is_not_reachable_from_the_outer_wall():
    assert goal_reachable(island_world([0.0, 0.7, 0.15]), "right") is False
    assert goal_reachable(island_world([0.0, 1.8, 0.15]), "right") is True
    # the left hand, 1.8 m from the island with no wall abeam, drives to the nearest: the outer wall
    assert goal_reachable(island_world([0.0, 0.7, 0.15]), "left") is False


def test_a_start_between_island_and_outer_wall_follows_the_wall_on_its_hand():
    world = island_world([0.0, 0.7, 0.15])
    world["boxes"] = [[-0.5, -1.5, 0.5, 0.5]]  # the island reaches down to 0.475 m from the outer wall
    world["start"] = [0.0, -1.75, 0.0]  # outer wall 0.225 m on the right, island 0.25 m on the left
    assert goal_reachable(world, "right") is False
    assert goal_reachable(world, "left") is True


@pytest.mark.parametrize(
    ("family", "options", "message"),
    [
        ("spiral", {}, "unknown maze family"),
        ("perfect", {"bend_deg": 30.0}, "unknown option 'bend_deg'"),
        ("perfect", {"width": -1.0}, "width must be a number in"),
        ("perfect", {"hand": "middle"}, "hand must be one of"),
        ("bends", {"bend_deg": float("nan")}, "bend_deg must be a number in"),
    ],
)
def test_bad_requests_name_what_is_wrong(family, options, message):
    with pytest.raises(MazeError, match=message):
        generate(family, 0, **options)


def test_negative_seed_is_refused():
    with pytest.raises(MazeError, match="seed"):
        generate("perfect", -1)
