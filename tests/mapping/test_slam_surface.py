"""A window's likelihood field is made of the surfaces its scans saw, not of their points alone
(amr_maps.scan_matcher.surface_points): a wall seen at a grazing angle far down a corridor has its hits up to a
metre apart, a field of the points alone is dotted there, and a new scan, which sees that stretch nearer and denser,
scored higher slid back towards the window: a step along a corridor was matched up to a third of a metre short."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_mapping.slam import GraphSlam, SlamConfig
from amr_maps.raycast import NumpyRayCaster
from amr_maps.scan_matcher import SURFACE_MIN_INCIDENCE, surface_points
from amr_maps.world import world_from_dict
from amr_util.geometry import compose, relative_pose
from amr_util.scan import ScanData

RESOLUTION = 0.05


def _wall_hits(bearings_deg, y: float = 1.2) -> np.ndarray:
    bearings = np.radians(np.asarray(bearings_deg, dtype=float))
    return np.column_stack([y / np.tan(bearings), np.full(len(bearings), y)])


def test_a_wall_seen_at_a_grazing_angle_is_filled_in_between_its_hits():
    hits = _wall_hits(np.arange(12.0, 90.0, 1.0))  # incidence 12-89 deg, hits up to 0.5 m apart
    surface = surface_points(hits, (0.0, 0.0), RESOLUTION)
    assert np.allclose(surface[:, 1], 1.2)  # on the wall
    assert np.allclose(surface[: len(hits)], hits)  # the hits kept, first
    # between the second and the last but one hit (a surface's end segments have no hit beyond them to confirm it)
    inner = np.sort(surface[(surface[:, 0] <= hits[1, 0] + 1e-9) & (surface[:, 0] >= hits[-2, 0] - 1e-9), 0])
    assert np.diff(inner).max() <= 2 * RESOLUTION + 1e-9, np.diff(inner).max()
    assert hits[1, 0] - hits[2, 0] > 0.3  # (there was something to fill)


def test_a_gap_the_hits_beside_it_do_not_continue_is_not_a_surface():
    """Two things at nearly the same range (clutter, a chair's legs): their hits' line is not the neighbours'."""
    hits = _wall_hits(np.arange(12.0, 20.0, 1.0))
    bent = hits.copy()
    bent[5:, 1] += 0.2  # a second wall 20 cm behind the first from the sixth hit on
    surface = surface_points(bent, (0.0, 0.0), RESOLUTION)
    across = (surface[:, 0] < bent[4, 0] - 1e-9) & (surface[:, 0] > bent[5, 0] + 1e-9)
    assert not across.any()
    within = (surface[:, 0] < bent[1, 0] - 1e-9) & (surface[:, 0] > bent[2, 0] + 1e-9)
    assert within.any()


def test_a_wall_shallower_than_the_incidence_is_not_filled():
    shallow = math.degrees(SURFACE_MIN_INCIDENCE) / 2
    hits = _wall_hits([shallow, shallow + 1.0])
    assert len(surface_points(hits, (0.0, 0.0), RESOLUTION)) == 2


def test_an_edge_between_a_near_thing_and_the_wall_behind_it_is_not_asurface_points():
    bearings = np.radians(np.arange(-10.0, 11.0, 1.0))
    reach = np.where(bearings < 0.0, 1.0, 3.0)  # a box 1 m ahead on the right, a wall 3 m ahead beyond it
    hits = np.column_stack([reach * np.cos(bearings), reach * np.sin(bearings)])
    surface = surface_points(hits, (0.0, 0.0), RESOLUTION)
    ranges = np.hypot(surface[:, 0], surface[:, 1])
    assert np.all((np.abs(ranges - 1.0) < 0.01) | (np.abs(ranges - 3.0) < 0.01)), "a fill between box and wall"


def test_beams_with_a_dropped_one_between_them_are_not_neighbours():
    bearings = [b for b in range(12, 25) if b != 18]  # the beam at 18 deg dropped (no return, NaN)
    hits = _wall_hits(bearings)
    surface = surface_points(hits, (0.0, 0.0), RESOLUTION)
    before, after = hits[bearings.index(17)], hits[bearings.index(19)]
    assert not ((surface[:, 0] < before[0] - 1e-9) & (surface[:, 0] > after[0] + 1e-9)).any()
    assert ((surface[:, 0] < hits[1, 0] - 1e-9) & (surface[:, 0] > hits[2, 0] + 1e-9)).any()


def test_the_sensor_mount_is_where_the_beams_come_from():
    hits = _wall_hits(np.arange(12.0, 90.0, 1.0))
    moved = surface_points(hits + [0.3, 0.0], (0.3, 0.0), RESOLUTION)
    assert np.allclose(np.sort(moved[:, 0]), np.sort(surface_points(hits, (0.0, 0.0), RESOLUTION)[:, 0] + 0.3))


def test_fewer_than_two_points_are_returned_as_they_are():
    assert surface_points(np.zeros((0, 2)), (0.0, 0.0), RESOLUTION).shape == (0, 2)
    assert np.allclose(surface_points(np.ones((1, 2)), (0.0, 0.0), RESOLUTION), [[1.0, 1.0]])


BEAMS = 181
FOV = math.pi
MAX_RANGE = 8.0


@pytest.fixture(scope="module")
def corridor_with_a_room():
    """A corridor 2.4 m wide and 24 m long, a room 9 x 3 m beside it through two doorways: nothing else along it."""
    walls = [[0, 0, 24, 0], [24, 0, 24, 2.4], [24, 2.4, 16, 2.4], [15, 2.4, 10, 2.4], [9, 2.4, 0, 2.4], [0, 2.4, 0, 0]]
    walls += [[8, 2.4, 8, 5.4], [8, 5.4, 17, 5.4], [17, 5.4, 17, 2.4]]
    world = world_from_dict({"walls": walls, "wall_thickness": 0.1, "start": [2, 1.2, 0]})
    return NumpyRayCaster(world.faces)


def _step_errors(caster, seed: int) -> list[float]:
    """Each step's position error (m): the laser 45 deg off the way the robot drives, 0.9 m keyframes, odometry 3 %
    long and a little noise, a seed."""
    rng = np.random.default_rng(seed)
    heading = math.pi / 4
    truth = np.array([(2.0 + 0.9 * k, 1.2 + 0.1 * math.sin(k + seed), heading) for k in range(21)])
    odometry = [np.zeros(3)]
    for k in range(1, len(truth)):
        step = np.array(relative_pose(truth[k - 1], truth[k]))
        step[:2] *= 1.03
        step += rng.normal(0.0, [0.01, 0.01, 0.005])
        odometry.append(np.array(compose(odometry[-1], step)))
    slam = GraphSlam(SlamConfig(max_range_used=MAX_RANGE, lidar_x=0.0, loop_min_travel=1000.0))
    increment = FOV / (BEAMS - 1)
    for k, (pose, odom) in enumerate(zip(truth, odometry, strict=True)):
        ranges = caster.cast(pose[0], pose[1], pose[2] - FOV / 2, increment, BEAMS, MAX_RANGE)
        scan = ScanData(ranges + rng.normal(0.0, 0.01, BEAMS), -FOV / 2, increment, 0.1, MAX_RANGE + 1.0)
        slam.add(k * 1_000_000_000, odom, scan)
    poses, _, _ = slam.graph()
    assert len(poses) == len(truth)
    errors = []
    for k in range(1, len(truth)):
        estimated, true = relative_pose(poses[k - 1], poses[k]), relative_pose(truth[k - 1], truth[k])
        errors.append(math.hypot(estimated[0] - true[0], estimated[1] - true[1]))
    return errors


def test_steps_along_a_corridor_are_matched_where_they_were_taken(corridor_with_a_room):
    """Each step within 5 cm on average over four runs (the field of the points alone: 6-8 cm a run, single steps
    22-35 cm short)."""
    errors = [_step_errors(corridor_with_a_room, seed) for seed in range(4)]
    assert np.mean(errors) < 0.05, np.round(np.mean(errors, axis=1), 3)
