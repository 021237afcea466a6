"""The front end matches only the scan points its window saw (slam._seen): where the window's scans did not look
(outside their fields of view, beyond the reach of a beam without a return) they saw no wall, and no wall there is
no evidence. Scored as clear
space, the new ground pulled every match towards where the window's surfaces end: a 180-degree laser driven away
from what it faces (the logs played backwards) had each 1 m step matched 20-50 cm short."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_mapping.slam import GraphSlam, SlamConfig, _seen
from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import world_from_dict
from amr_util.geometry import compose, relative_pose
from amr_util.scan import ScanData

BEAMS = 181
FOV = math.pi
MAX_RANGE = 8.0


def _view(reach: float = 2.0, beams: int = 181, fov: float = math.pi):
    """A view from the origin facing +x: beams over `fov`, each reaching `reach` (as beams without a return do)."""
    angles = np.linspace(-fov / 2, fov / 2, beams)
    return np.zeros(3), angles, np.full(beams, reach)


def test_a_point_is_seen_within_a_views_field_and_reach():
    points = np.array([[1.0, 0.0], [0.5, 1.0], [-0.5, 0.2], [2.1, 0.0], [3.0, 0.0], [0.0, -1.5]])
    seen = _seen(points, [_view()], 0.2)
    # ahead, ahead and to the side, behind the sensor, just beyond the reach, far beyond, at -90 deg
    assert seen.tolist() == [True, True, False, True, False, True]


def test_a_point_beyond_the_reach_by_less_than_its_margin_is_seen():
    """The margin (a point's own: how far the search can move it) counts a point just beyond a beam's reach as seen."""
    points = np.array([[2.4, 0.0], [2.4, 0.0]])
    assert _seen(points, [_view()], np.array([0.2, 0.5])).tolist() == [False, True]


def test_each_beam_has_its_own_reach_and_a_dropped_beams_gap_sees_nothing():
    sensor, angles, reach = _view(reach=3.0)
    reach = reach.copy()
    ahead = np.argmin(np.abs(angles))
    reach[ahead - 2 : ahead + 3] = 1.0  # these beams reach 1 m
    points = np.array([[0.9, 0.0], [2.5, 0.0], [2.5, 0.5]])
    assert _seen(points, [(sensor, angles, reach)], 0.2).tolist() == [True, False, True]
    keep = np.abs(angles - 0.5) > 0.05  # beams near 0.5 rad dropped (NaN readings)
    point = np.array([[math.cos(0.5), math.sin(0.5)]])
    assert not _seen(point, [(sensor, angles[keep], np.full(keep.sum(), 3.0))], 0.2)[0]


def test_a_360_degree_views_last_and_first_beams_are_neighbours():
    behind = np.array([[-1.0, 0.001], [-1.0, -0.001]])
    assert _seen(behind, [_view(beams=360, fov=2 * math.pi * 359 / 360)], 0.2).all()


def test_several_views_see_their_union():
    ahead = _view()
    turned = (np.array([0.0, 0.0, math.pi]), *_view()[1:])
    points = np.array([[1.0, 0.0], [-1.0, 0.0]])
    assert _seen(points, [ahead], 0.2).tolist() == [True, False]
    assert _seen(points, [ahead, turned], 0.2).all()


def test_a_beam_that_hit_something_sees_along_its_whole_line():
    """Behind a surface a beam hit, a point scores by its distance from it: it stays (judged at a prior off by more
    than its window, the points contradicting the prior would be the ones dropped); a beam without a return reaches
    its clear range, beyond which the window has no point."""
    slam = GraphSlam(SlamConfig(max_range_used=5.0, lidar_x=0.0))
    ranges = np.full(BEAMS, np.inf)
    ranges[:90] = 2.0
    slam.add(0, (0.0, 0.0, 0.0), ScanData(ranges, -FOV / 2, FOV / (BEAMS - 1), 0.1, 8.0))
    [(sensor, angles, reach)] = slam._views(0, [0])
    assert np.allclose(sensor, 0.0) and np.all(np.diff(angles) > 0)
    assert np.isinf(reach[:90]).all() and np.allclose(reach[90:], 5.0)


@pytest.fixture(scope="module")
def corridor():
    """A corridor 2.4 m wide and 24 m long, closed at both ends, boxes along its walls every few metres."""
    boxes = [[x, 0, x + 0.4, 0.3] for x in (3.0, 8.5, 13.0, 19.0)] + [[x, 2.1, x + 0.3, 2.4] for x in (5.5, 11.0, 16.5)]
    world = world_from_dict(
        {
            "walls": [[0, 0, 24, 0], [24, 0, 24, 2.4], [24, 2.4, 0, 2.4], [0, 2.4, 0, 0]],
            "wall_thickness": 0.1,
            "start": [20, 1.2, 0],
            "boxes": boxes,
        }
    )
    return NumpyRayCaster(world.faces)


def _steps_driving_away(caster, heading: float, seed: int = 0) -> np.ndarray:
    """(N, 2) each node's step error against the truth (m, rad): the robot faces `heading` and drives down the
    corridor in -x, 0.9 m keyframes, its odometry 3 % long."""
    rng = np.random.default_rng(seed)
    truth = np.array([(21.0 - 0.9 * k, 1.2 + 0.1 * math.sin(k), heading) for k in range(20)])
    odometry = [np.zeros(3)]
    for k in range(1, len(truth)):
        step = np.array(relative_pose(truth[k - 1], truth[k]))
        step[:2] *= 1.03
        odometry.append(np.array(compose(odometry[-1], step)))
    slam = GraphSlam(SlamConfig(max_range_used=MAX_RANGE, lidar_x=0.0))
    for k, (pose, odom) in enumerate(zip(truth, odometry, strict=True)):
        increment = FOV / (BEAMS - 1)
        ranges = caster.cast(pose[0], pose[1], pose[2] - FOV / 2, increment, BEAMS, MAX_RANGE)
        scan = ScanData(ranges + rng.normal(0.0, 0.01, BEAMS), -FOV / 2, increment, 0.1, MAX_RANGE + 1.0)
        slam.add(k * 1_000_000_000, odom, scan)
    poses, _, _ = slam.graph()
    assert len(poses) == len(truth)
    errors = []
    for k in range(1, len(truth)):
        estimated, true = relative_pose(poses[k - 1], poses[k]), relative_pose(truth[k - 1], truth[k])
        errors.append((math.hypot(estimated[0] - true[0], estimated[1] - true[1]), abs(estimated[2] - true[2])))
    return np.array(errors)


@pytest.mark.parametrize("heading", [0.0, math.pi], ids=["facing away from the way it drives", "facing the way"])
def test_a_scan_is_matched_where_it_was_taken_whichever_way_the_laser_faces(corridor, heading):
    errors = _steps_driving_away(corridor, heading)
    assert errors[:, 0].max() < 0.08, np.round(errors[:, 0], 3)
    assert errors[:, 0].mean() < 0.03, np.round(errors[:, 0], 3)
    assert errors[:, 1].max() < math.radians(1.0)
