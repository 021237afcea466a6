"""GraphSlam's model terms found on the CARMEN logs: along a featureless corridor the scan match says nothing
about the position along it (its information, fused with the odometry's); a beam without a return clears free
space only up to the sensor's range_max; a SLAM map put in the world's frame (amr_mapping.map_frame); the front
end takes the posterior's mode (score and odometry prior), not the best score alone."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_mapping import slam as slam_module
from amr_mapping.errors import MappingError
from amr_mapping.map_frame import map_in_world
from amr_mapping.slam import GraphSlam, SlamConfig, _match_information
from amr_maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid
from amr_maps.raycast import NumpyRayCaster
from amr_maps.scan_matcher import CorrelativeMatcher, ScoreMap
from amr_maps.world import world_from_dict
from amr_util.scan import ScanData

BEAMS = 180
INCREMENT = 2.0 * math.pi / BEAMS


def test_a_corridor_match_is_informative_across_it_and_not_along_it():
    """The match information (the score's curvature): a 40 m corridor 1.6 m wide seen by a 6 m LiDAR tells the
    lateral position and the heading, not the position along it, where the odometry it is fused with decides."""
    world = world_from_dict(
        {"walls": [[-20, -0.8, 20, -0.8], [-20, 0.8, 20, 0.8]], "wall_thickness": 0.1, "start": [0, 0, 0]}
    )
    caster = NumpyRayCaster(world.faces)
    rng = np.random.default_rng(5)
    angles = -math.pi + INCREMENT * np.arange(BEAMS)

    def scan_points(x: float) -> np.ndarray:  # the scan at (x, 0, 0), in the robot's frame
        ranges = caster.cast(x, 0.0, -math.pi, INCREMENT, BEAMS, 6.0) + rng.normal(0.0, 0.01, BEAMS)
        keep = ranges < 6.0
        return np.column_stack([ranges[keep] * np.cos(angles[keep]), ranges[keep] * np.sin(angles[keep])])

    data = np.zeros((60, 600), dtype=np.int8)  # the submap: the scans of three poses behind, rasterized
    for x in (-0.9, -0.6, -0.3):
        cloud = scan_points(x) + (x, 0.0)
        data[np.floor((cloud[:, 1] + 1.5) / 0.05).astype(int), np.floor((cloud[:, 0] + 15.0) / 0.05).astype(int)] = (
            OCCUPIED
        )
    grid = OccupancyGrid(data, 0.05, (-15.0, -1.5, 0.0))
    points = scan_points(0.0)
    matcher = CorrelativeMatcher(ScoreMap.from_occupancy(grid, sigma=0.075))
    information = _match_information(matcher, points, np.zeros(3), 0.05)
    sigma = np.sqrt(np.diag(np.linalg.inv(information)))
    assert sigma[1] < 0.05 and sigma[2] < math.radians(2.0)  # across, heading: a few cm, a degree
    assert sigma[0] > 20 * sigma[1]  # along: no better than the odometry it is fused with


def test_a_beam_without_a_return_clears_up_to_the_sensors_range_only():
    """No return at all from a 3.5 m LiDAR: the map is free space within 3.5 m, not max_range_used's 20."""
    slam = GraphSlam(SlamConfig(max_range_used=20.0))
    slam.add(0, (0.0, 0.0, 0.0), ScanData(np.full(360, np.inf), -math.pi, 2 * math.pi / 360, 0.12, 3.5))
    grid = slam.occupancy_grid()
    x0, y0, x1, y1 = grid.bounds
    assert max(abs(x0), x1, abs(y0), y1) < 3.5 + 2.5  # the log-odds grid's growth margin (2 m) at most
    free = (grid.data >= 0) & (grid.data < 50)
    assert free.sum() * grid.resolution**2 == pytest.approx(math.pi * 3.5**2, rel=0.1)


def _one_cell_grid() -> OccupancyGrid:
    data = np.full((40, 60), 0, dtype=np.int8)
    data[10, 50] = OCCUPIED  # the cell whose centre is (2.525, 0.525) in the SLAM frame (origin (-0.0, 0.0))
    return OccupancyGrid(data, 0.05, (0.0, 0.0, 0.0))


@pytest.mark.parametrize("start", [(1.0, -2.0, 0.0), (1.0, -2.0, math.pi / 2), (-0.3, 0.4, 2.5)])
def test_map_in_world_puts_each_cell_at_start_compose_its_slam_position(start):
    slam_grid = _one_cell_grid()
    world = map_in_world(slam_grid, start)
    assert world.resolution == slam_grid.resolution and world.origin[2] == 0.0
    c, s = math.cos(start[2]), math.sin(start[2])
    x, y = 2.525, 0.525
    wx, wy = start[0] + c * x - s * y, start[1] + s * x + c * y
    row, col = world.world_to_cell(wx, wy)
    assert world.data[int(row), int(col)] == OCCUPIED
    assert (world.data == OCCUPIED).sum() <= 2  # nearest-cell resampling: one cell, two at most
    assert (world.data == UNKNOWN).any() == (abs(math.sin(2 * start[2])) > 1e-9)  # rotated: corners unknown
    assert (world.data == 0).sum() == pytest.approx((slam_grid.data == 0).sum(), rel=0.03)


def test_map_in_world_refuses_a_start_that_is_not_a_pose():
    with pytest.raises(MappingError, match="start"):
        map_in_world(_one_cell_grid(), (0.0, math.nan, 0.0))


def test_the_scan_is_placed_at_the_lidar_mount():
    """A LiDAR 0.5 m behind the robot's origin (lidar_x -0.5) sees a wall 1 m ahead of the robot at 1.5 m: the
    map has the wall at x = 1 (without the mount it would be at 1.5), and the points matched are the robot's."""
    angles = np.linspace(-0.3, 0.3, 61)
    ranges = 1.5 / np.cos(angles)
    scan = ScanData(ranges, -0.3, 0.01, 0.1, 5.0)
    for lidar_x, wall in ((-0.5, 1.0), (0.0, 1.5)):
        slam = GraphSlam(SlamConfig(lidar_x=lidar_x))
        slam.add(0, (0.0, 0.0, 0.0), scan)
        grid = slam.occupancy_grid()
        rows, cols = np.nonzero(grid.occupied())
        x, _ = grid.cell_to_world(rows, cols)
        assert np.median(x) == pytest.approx(wall, abs=0.05)
    with pytest.raises(MappingError, match="lidar_yaw"):
        SlamConfig(lidar_yaw=math.inf)


class _NoReference:
    matcher = None


_NO_REFERENCE = _NoReference()


def test_a_match_and_its_refinement_are_weighed_by_their_informations(monkeypatch):
    """The front end's pose: the correlative match (its information with the field's quantization) and its
    point-to-line refinement (at ALIGN_WEIGHT_SHARE of its information), each weighted by its information, the odometry
    weighed against the more informative one's. A refinement claiming 100 times the match's precision (a simulated
    maze's straight walls) decides; one claiming a fiftieth of it (a real log's clutter) moves the pose a fifth of the
    way or less (taking it whatever its information cost the logs 0.40 vs 0.26 deg a link on aces). The estimate's
    covariance is the deciding one's own: the refinement's full information's inverse, or the match's."""
    curvature = np.diag([1e4, 1e4, 1e5])
    monkeypatch.setattr(slam_module, "_match_information", lambda *args: curvature)
    # the directions the surfaces leave free are test_slam_covariance's: here every direction is constrained
    monkeypatch.setattr(slam_module, "_constrained", lambda information, *args: information)
    points = np.column_stack([2.0 * np.cos(np.linspace(0, 6, 30)), 2.0 * np.sin(np.linspace(0, 6, 30))])  # 2 m
    match_information = slam_module._with_quantization(curvature, points, 0.05)
    q = 0.05 / math.sqrt(12.0)
    assert np.allclose(
        np.linalg.inv(match_information), np.linalg.inv(curvature) + np.diag([q * q, q * q, (q / 2) ** 2])
    )
    pose = np.array([1.0, 2.0, 0.5])
    refined = pose + np.array([0.02, -0.01, 0.004])
    for share in (100.0, 0.02):
        weight = share * curvature
        own = weight / slam_module.ALIGN_WEIGHT_SHARE  # the refinement's Gauss-Newton information
        monkeypatch.setattr(slam_module, "_align", lambda *args, i=own: (refined.copy(), i))
        fused, information, covariance = slam_module._refined(_NO_REFERENCE, points, pose, 0.05)
        expected = pose + np.linalg.solve(match_information + weight, weight @ (refined - pose))
        assert fused == pytest.approx(expected, abs=1e-12)
        toward = (fused - pose) / (refined - pose)
        if share > 1.0:
            assert np.all(toward > 0.95) and np.allclose(information, weight)
            assert np.allclose(covariance, np.linalg.inv(own))
        else:
            assert np.all(toward < 0.2) and np.allclose(information, match_information)
            assert np.allclose(covariance, np.linalg.inv(match_information))
    monkeypatch.setattr(slam_module, "_align", lambda *args: (refined.copy(), None))  # too few pairs: the match
    fused, information, covariance = slam_module._refined(_NO_REFERENCE, points, pose, 0.05)
    assert np.array_equal(fused, pose) and np.allclose(information, match_information)
    assert np.allclose(covariance, np.linalg.inv(match_information))


def test_the_field_measures_the_distance_to_the_points_not_to_their_cells():
    """The submap's likelihood field at a cell's centre: exp(-d^2 / 2 sigma^2) with d the distance to the points
    themselves (a wall at x = 0.0374, its cells' centres at 0.025 and 0.075: 12.4 and 37.6 mm); rasterized (the
    distance to the cell holding the points) the wall's own cells scored 1 and their neighbours alike."""
    wall = np.column_stack([np.full(200, 0.0374), np.linspace(-2.0, 2.0, 200)])
    sigma = 0.075
    field = ScoreMap.from_points(wall, 0.05, sigma, 1.5, cover=np.zeros((1, 2)), to_points=True)
    centres = field.origin[0] + (np.arange(field.table.shape[1]) + 0.5) * 0.05
    row = field.table[field.table.shape[0] // 2]
    expected = np.exp(-0.5 * ((centres - 0.0374) / sigma) ** 2)
    assert np.allclose(row, expected, atol=0.02)  # the nearest cell's points' mean: its y a little off the row's
    rasterized = ScoreMap.from_points(wall, 0.05, sigma, 1.5, cover=np.zeros((1, 2)))
    column = int(np.argmin(np.abs(centres - 0.025)))
    assert rasterized.table[rasterized.table.shape[0] // 2, column] == pytest.approx(1.0)
    assert row[column] == pytest.approx(math.exp(-0.5 * (0.0124 / sigma) ** 2), abs=0.005)
    assert row[column] < 0.99


@pytest.mark.parametrize(("odometry_sigma", "expected_x"), [(0.1, 0.0), (1.0, 0.4)])
def test_the_front_end_takes_the_posteriors_mode_not_the_best_score(odometry_sigma, expected_x):
    """Two copies of a scene 0.4 m apart, the one at the odometry prior missing a point: the scan scores best at
    the other copy (as along a corridor where a door lines up, aces: 0.3-0.47 m off, 0.02 of score better), but
    the odometry's penalty there outweighs the score (its likelihood at MATCH_INFORMATION_SCALE) when the odometry
    says 10 cm; said 1 m, the best score wins."""
    rng = np.random.default_rng(3)
    scene = rng.uniform(-2.0, 2.0, (60, 2))
    cloud = np.vstack([scene[1:], scene + (0.4, 0.0)])  # the copy at 0 lacks its first point
    table = ScoreMap.from_points(cloud, 0.05, 0.075, 1.5, cover=np.zeros((1, 2)), to_points=True)
    matcher = CorrelativeMatcher(table)
    prior = np.zeros(3)
    best = matcher.match(scene, prior, 0.6, 0.1)
    assert abs(best.pose[0] - 0.4) < 0.03  # the best score alone: the other copy
    sigma = np.array([odometry_sigma, odometry_sigma, 0.05])
    work = slam_module._Work()
    chosen = slam_module._posterior_mode(matcher, scene, best, prior, np.diag(1.0 / sigma**2), (0.6, 0.1), work)
    assert abs(chosen.pose[0] - expected_x) < 0.03 and abs(chosen.pose[1]) < 0.03, chosen.pose
    # the search for modes is counted work, and is not done when the odometry's penalty is worth next to no score
    assert (work.units > 0.0) == (odometry_sigma < 1.0)
