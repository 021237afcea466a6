"""LiDAR: known distances, range limits (REP 117), noise, and the two ray casters agreeing."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from support.simulation import WORLDS, make_config

from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import load_world, world_from_dict
from amr_simulation.lidar import Lidar
from amr_simulation.physics import WALLS_ONLY, Physics
from amr_simulation.raycast import PymunkRayCaster
from amr_simulation.simulator import Simulator
from amr_util.geometry import Pose2D

# Inner faces at x = +-1.95 and y = +-0.95.
BOX_ROOM = world_from_dict(
    {
        "wall_thickness": 0.1,
        "walls": [[-2.0, -1.0, 2.0, -1.0], [2.0, -1.0, 2.0, 1.0], [2.0, 1.0, -2.0, 1.0], [-2.0, 1.0, -2.0, -1.0]],
        "start": [0.0, 0.0, 0.0],
    }
)
AHEAD, LEFT, BEHIND, RIGHT = 0, 60, 120, 180  # beam indices of 240 over 360 deg


def test_beams_read_known_distances_within_noise() -> None:
    sim = Simulator(BOX_ROOM, make_config(lidar={"x": 0.0, "noise_std": 0.01}))
    ranges = np.asarray(sim.ranges)
    expected = {AHEAD: 1.95, LEFT: 0.95, BEHIND: 1.95, RIGHT: 0.95}
    for beam, distance in expected.items():
        assert abs(ranges[beam] - distance) < 5 * 0.01
    # beam 30 points 45 deg left: it meets the side wall at 0.95 * sqrt(2)
    assert abs(ranges[30] - 0.95 * math.sqrt(2.0)) < 5 * 0.01


def test_beams_follow_the_heading_and_the_sensor_offset() -> None:
    sim = Simulator(BOX_ROOM, make_config(start=(0.5, 0.0, 0.5 * math.pi)))  # sensor 3.2 cm behind the axle
    ranges = np.asarray(sim.ranges)
    assert ranges[AHEAD] == pytest.approx(0.95 + 0.032)
    assert ranges[BEHIND] == pytest.approx(0.95 - 0.032)
    assert ranges[RIGHT] == pytest.approx(1.95 - 0.5)
    assert ranges[LEFT] == pytest.approx(1.95 + 0.5)


def test_out_of_range_reads_inf_and_too_close_reads_minus_inf() -> None:
    sim = Simulator(BOX_ROOM, make_config(lidar={"range_max": 1.0, "noise_std": 0.01}))
    ranges = np.asarray(sim.ranges)
    assert ranges[AHEAD] == math.inf and ranges[BEHIND] == math.inf
    assert 0.9 < ranges[LEFT] <= 1.0
    # back 1 cm from the west wall: the sensor, 3.2 cm behind the axle, is 8.3 cm from it
    sim.set_pose(-1.95 + 0.105 + 0.01, 0.0, 0.0)
    assert np.asarray(sim.ranges)[BEHIND] == -math.inf
    assert np.all(np.abs(np.asarray(sim.ranges)) >= sim.lidar.range_min)


def test_noise_is_unbiased_with_the_configured_spread() -> None:
    sim = Simulator(BOX_ROOM, make_config(lidar={"noise_std": 0.01, "x": 0.0}))
    truth = sim._lidar.true_ranges(sim.pose)
    errors = np.concatenate([np.asarray(sim.ranges) - truth] + [sim._lidar.scan(sim.pose) - truth for _ in range(20)])
    assert abs(errors.mean()) < 0.002
    assert 0.009 < errors.std() < 0.011


def test_scan_geometry_for_laser_scan_messages() -> None:
    lidar = make_config().lidar
    assert lidar.beams == 240 and lidar.angle_min == 0.0
    assert lidar.angle_increment == pytest.approx(2.0 * math.pi / 240)
    assert lidar.angle_max == pytest.approx(2.0 * math.pi - lidar.angle_increment)
    assert (lidar.range_min, lidar.range_max) == (0.12, 3.5)


def free_poses(world, physics: Physics, count: int, rng: np.random.Generator) -> list[Pose2D]:
    xmin, ymin, xmax, ymax = world.bounds
    poses = []
    while len(poses) < count:
        x, y = rng.uniform(xmin, xmax), rng.uniform(ymin, ymax)
        if physics.clearance(x, y) >= physics.radius:
            poses.append(Pose2D(x, y, rng.uniform(-math.pi, math.pi)))
    return poses


@pytest.mark.parametrize("name", sorted(p.name for p in WORLDS.glob("*.yaml")))
@pytest.mark.parametrize(
    "lidar",
    [{}, {"beams": 1440}, {"beams": 100, "fov": 1.5 * math.pi, "angle_min": -0.75 * math.pi}, {"range_max": 1.0}],
    ids=["default", "1440-beams", "270-deg", "short-range"],
)
def test_numpy_and_pymunk_casts_agree(name: str, lidar: dict) -> None:
    world = load_world(WORLDS / name)
    config = make_config(lidar=lidar).lidar
    physics = Physics(world.polygons, 0.105)
    casters = NumpyRayCaster(world.faces), PymunkRayCaster(physics.space, WALLS_ONLY)
    lidars = [Lidar(config, caster, np.random.default_rng(0)) for caster in casters]
    for pose in free_poses(world, physics, 15, np.random.default_rng(1)):
        fast, reference = (lidar.scan(pose) for lidar in lidars)
        assert np.array_equal(np.isinf(fast), np.isinf(reference))
        finite = np.isfinite(reference)
        assert finite.any()
        np.testing.assert_allclose(fast[finite], reference[finite], atol=1e-9)


def test_beam_through_a_corner_hits_it() -> None:
    # Beam 30 from the centre of a 2 x 2 box aims exactly at its corner.
    world = world_from_dict({"boxes": [[1.0, 1.0, 3.0, 3.0]], "start": [0.0, 0.0, 0.0]})
    ranges = NumpyRayCaster(world.faces).cast(0.0, 0.0, 0.0, 2.0 * math.pi / 240, 240, 3.5)
    assert ranges[30] == pytest.approx(math.sqrt(2.0))
    assert np.isinf(ranges[90:]).all()


@settings(max_examples=60, deadline=None)
@given(
    walls=st.lists(
        st.tuples(*[st.floats(-2.0, 2.0)] * 4, st.floats(0.005, 0.2)).filter(
            lambda w: math.hypot(w[2] - w[0], w[3] - w[1]) > 0.01
        ),
        min_size=1,
        max_size=12,
    ),
    origin=st.tuples(st.floats(-2.5, 2.5), st.floats(-2.5, 2.5)),
    phi0=st.floats(-math.pi, math.pi),
    beams=st.integers(1, 400),
)
def test_casters_agree_on_random_walls(walls, origin, phi0, beams) -> None:
    polygons, faces = [], []
    for x1, y1, x2, y2, thickness in walls:  # each its own thickness
        world = world_from_dict({"wall_thickness": thickness, "walls": [[x1, y1, x2, y2]], "start": [0.0, 0.0, 0.0]})
        polygons.extend(world.polygons)
        faces.append(world.faces)
    physics = Physics(polygons, 0.105)
    assume(physics.clearance(*origin) > 1e-3)  # outside every wall
    increment = 2.0 * math.pi / beams
    fast = NumpyRayCaster(np.concatenate(faces)).cast(*origin, phi0, increment, beams, 3.0)
    reference = PymunkRayCaster(physics.space, WALLS_ONLY).cast(*origin, phi0, increment, beams, 3.0)
    fast[fast > 3.0] = np.inf
    assert np.array_equal(np.isinf(fast), np.isinf(reference))
    finite = np.isfinite(reference)
    np.testing.assert_allclose(fast[finite], reference[finite], atol=1e-7)
