"""Collisions: counted once per impact, and walls are never passed through."""

from __future__ import annotations

import math

import pytest
from support.simulation import WORLDS, make_config

from amr_maps.world import load_world, world_from_dict
from amr_simulation.simulator import Simulator

RADIUS = 0.105


def thin_wall_world(thickness: float):
    """A wall along x = 1 (faces at 1 -+ thickness / 2) in front of a robot at the origin."""
    return world_from_dict({"wall_thickness": thickness, "walls": [[1.0, -2.0, 1.0, 2.0]], "start": [0.0, 0.0, 0.0]})


@pytest.mark.parametrize(("thickness", "dt"), [(0.01, 0.05), (0.05, 0.05), (0.01, 0.5), (0.01, 1.0)])
def test_ramming_a_wall_counts_one_collision_and_never_passes(thickness: float, dt: float) -> None:
    sim = Simulator(thin_wall_world(thickness), make_config(dt=dt))
    face = 1.0 - thickness / 2
    for _ in range(int(10.0 / dt)):
        sim.step(1.0, 0.0)  # saturated to 0.22 m/s
        assert sim.pose.x + RADIUS <= face + 0.011  # at most one substep of travel inside
    assert sim.collisions == 1 and sim.in_contact
    assert sim.pose.x + RADIUS == pytest.approx(face, abs=0.002)


def test_pushing_diagonally_slides_along_the_wall() -> None:
    sim = Simulator(thin_wall_world(0.02), make_config())
    sim.set_pose(0.8, 0.0, math.radians(30.0))
    for _ in range(100):
        sim.step(0.2, 0.0)
    assert sim.collisions == 1
    assert sim.pose.x + RADIUS == pytest.approx(0.99, abs=0.002)
    assert sim.pose.y > 0.4  # sin(30 deg) of 5 s at 0.2 m/s, 0.5 m
    assert sim.twist[1] > 0.05  # the slide shows as sideways ground-truth velocity


def test_backing_off_and_hitting_again_counts_twice() -> None:
    sim = Simulator(thin_wall_world(0.02), make_config())
    for command, steps in ((0.2, 120), (-0.2, 40), (0.2, 60)):  # contact after 89 steps
        for _ in range(steps):
            sim.step(command, 0.0)
    assert sim.collisions == 2
    sim.reset()
    assert sim.collisions == 0 and not sim.in_contact


def test_a_corner_of_two_walls_is_one_collision() -> None:
    world = load_world(WORLDS / "outer_corridor.yaml")
    sim = Simulator(world, make_config())
    sim.set_pose(1.0, 1.0, math.radians(45.0))  # the north-east corner cell, facing the corner
    for _ in range(60):
        sim.step(0.2, 0.0)
    assert sim.collisions == 1
    assert sim.pose.x + RADIUS == pytest.approx(1.19, abs=0.002)
    assert sim.pose.y + RADIUS == pytest.approx(1.19, abs=0.002)
