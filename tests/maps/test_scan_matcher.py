"""amr_maps.scan_matcher: offsets recovered, branch and bound = brute force, global search, budget, covariance."""

import math
from itertools import pairwise

import numpy as np
import pytest

from amr_maps.maze_families import generate
from amr_maps.occupancy_grid import OccupancyGrid
from amr_maps.rasterize import rasterize_world
from amr_maps.raycast import NumpyRayCaster
from amr_maps.scan_matcher import (
    FIELD_REACH,
    CorrelativeMatcher,
    GlobalSearch,
    ScoreMap,
    WindowMatch,
    _cells,
    _lattice_totals,
    _max_pyramid,
    _node_total,
)
from amr_maps.world import world_from_dict

BEAMS = 180


def scan_points(world, pose, noise=0.0, seed=0, max_range=3.5):
    increment = 2.0 * math.pi / BEAMS
    angles = -math.pi + increment * np.arange(BEAMS)
    ranges = NumpyRayCaster(world.faces).cast(pose[0], pose[1], pose[2] - math.pi, increment, BEAMS, max_range)
    ranges = ranges + np.random.default_rng(seed).normal(0.0, noise, BEAMS)
    keep = np.isfinite(ranges) & (ranges < max_range)
    return np.column_stack([ranges[keep] * np.cos(angles[keep]), ranges[keep] * np.sin(angles[keep])])


@pytest.fixture(scope="module")
def pillars():
    world = world_from_dict(generate("pillars", 3, size=6.0))
    grid = rasterize_world(world, 0.05)
    return world, grid, CorrelativeMatcher(ScoreMap.from_occupancy(grid))


def test_score_map_from_occupancy_is_a_likelihood_field_with_unknown_floor():
    data = np.zeros((5, 7), dtype=np.int8)
    data[2, 3] = 100
    data[:, 0] = -1
    score = ScoreMap.from_occupancy(OccupancyGrid(data, 0.1, (1.0, 2.0, 0.0)), sigma=0.1, unknown=0.2)
    assert score.table[2, 3] == 1.0
    assert score.table[2, 4] == pytest.approx(math.exp(-0.5), rel=1e-6)
    assert score.table[2, 0] == pytest.approx(0.2)  # unknown, 3 cells from the wall
    assert score.origin == (1.0, 2.0) and not score.free[2, 3] and not score.free[2, 0] and score.free[1, 1]
    empty = ScoreMap.from_occupancy(OccupancyGrid(np.zeros((3, 3), np.int8), 0.1))
    assert empty.table.max() == 0.0


def test_pyramid_level_k_is_the_max_over_the_window_starting_at_each_cell():
    base = np.random.default_rng(3).integers(0, 1000, (13, 11)).astype(np.uint16)
    pyramid = _max_pyramid(base, 4)
    for level in range(4):
        size = 1 << level
        for r in range(13):
            for c in range(11):
                assert pyramid[level, r, c] == base[r : r + size, c : c + size].max()


def test_points_off_the_table_score_zero_and_bad_points_are_dropped():
    matcher = CorrelativeMatcher(ScoreMap.from_probability(np.ones((10, 10)), 0.1, (0.0, 0.0)))
    points = np.array([[0.5, 0.5], [5.0, 5.0], [np.nan, 0.2], [-0.05, 0.5]])
    assert matcher.score(points, (0.0, 0.0, 0.0)) == pytest.approx(1.0 / 3.0)
    found = matcher.match(np.zeros((0, 2)), (0.3, 0.4, 0.5), 0.2, 0.1)
    assert found.score == 0.0 and np.allclose(found.pose, (0.3, 0.4, 0.5))
    with pytest.raises(ValueError, match="prior"):
        matcher.match(points, (0.0, np.nan, 0.0), 0.2, 0.1)


@pytest.mark.parametrize(
    "offset",
    [
        (0.0, 0.0, 0.0),
        (0.3, -0.2, 0.0),
        (-0.15, 0.35, math.radians(12)),
        (0.42, 0.41, -math.radians(18)),
        (0.07, -0.03, math.radians(4)),
    ],
)
def test_match_recovers_known_offsets(pillars, offset):
    world, _, matcher = pillars
    truth = np.array([world.start.x, world.start.y, world.start.theta])
    points = scan_points(world, truth, noise=0.01, seed=1)
    found = matcher.match(points, truth - offset, 0.5, math.radians(20))
    assert found.exhaustive
    # a rasterized wall fills its boundary cells: the surface seen sits up to half a cell from where the map has it
    assert math.hypot(*(found.pose[:2] - truth[:2])) < 0.03
    assert abs(math.remainder(found.pose[2] - truth[2], 2 * math.pi)) < math.radians(1.0)
    assert 0.8 < found.score <= 1.0


def test_refinement_goes_below_the_cell(pillars):
    world, grid, _ = pillars
    centres = np.column_stack([c.ravel() for c in grid.cell_to_world(*np.indices(grid.data.shape))])
    distance = np.abs(world.clearance(centres)).reshape(grid.data.shape)  # to the surfaces, exact
    matcher = CorrelativeMatcher(ScoreMap.from_probability(np.exp(-0.5 * (distance / 0.1) ** 2), 0.05, grid.origin[:2]))
    truth = np.array([world.start.x + 0.021, world.start.y - 0.013, world.start.theta + 0.004])
    points = scan_points(world, truth)
    prior = truth + (0.123, 0.077, 0.05)  # the lattice passes 2.3 cm, 2.7 cm from the truth
    coarse = matcher.match(points, prior, 0.3, 0.1, refine=False)
    fine = matcher.match(points, prior, 0.3, 0.1)
    # bilinear interpolation peaks at cell centres: walls all on one sub-cell offset (an axis-aligned room) keep
    # a bias of a fraction of a cell
    error, lattice_error = (math.hypot(*(m.pose[:2] - truth[:2])) for m in (fine, coarse))
    assert error < 0.012 and error < 0.5 * lattice_error
    assert fine.score >= matcher.score_interpolated(points, coarse.pose)


@pytest.mark.parametrize("seed", range(4))
def test_branch_and_bound_equals_brute_force(seed):
    rng = np.random.default_rng(seed)
    prob = np.clip(rng.random((40, 36)) ** 3 + (rng.random((40, 36)) < 0.05), 0.0, 1.0)
    matcher = CorrelativeMatcher(ScoreMap.from_probability(prob, 0.1, (-1.0, -2.0)), levels=3 + seed % 2)
    points = rng.uniform(-1.0, 1.0, (25, 2))
    prior = np.array([0.8, 0.1, rng.uniform(-3, 3)])
    step, window = 0.05, 0.3
    found = matcher.match(points, prior, window, 0.1, angular_step=step, refine=False)
    best = max(
        matcher.score(points, prior + (dx * 0.1, dy * 0.1, da * step))
        for dx in range(-3, 4)
        for dy in range(-3, 4)
        for da in range(-2, 3)
    )
    assert found.exhaustive and found.score == pytest.approx(best, abs=1e-12)
    assert matcher.score(points, found.pose) == pytest.approx(found.score, abs=1e-12)
    brute_nodes = 7 * 7 * 5
    assert found.nodes < 4 * brute_nodes  # it prunes (a table of noise prunes little)


def test_global_search_equals_brute_force_on_a_small_map():
    rng = np.random.default_rng(7)
    prob = np.clip(rng.random((24, 20)) ** 4, 0.0, 1.0)
    matcher = CorrelativeMatcher(ScoreMap.from_probability(prob, 0.1, (0.0, 0.0)), levels=3)
    points = rng.uniform(-0.6, 0.6, (15, 2))
    found = matcher.search(
        points, np.ones(prob.shape, dtype=bool), angular_step=2 * math.pi / 16, count=1, refine=False, max_nodes=10**7
    )
    centres = [(0.05 + 0.1 * c, 0.05 + 0.1 * r) for r in range(24) for c in range(20)]
    best = max(matcher.score(points, (x, y, a * 2 * math.pi / 16)) for x, y in centres for a in range(16))
    assert len(found) == 1 and found[0].exhaustive and found[0].score == pytest.approx(best, abs=1e-12)


def twin_rooms():
    """Two 3 m rooms side by side with the same pillars, and one pillar more in the left room."""
    walls, boxes = [], []
    for x0 in (0.0, 3.5):
        walls += [
            [x0, 0.0, x0 + 3.0, 0.0],
            [x0 + 3.0, 0.0, x0 + 3.0, 3.0],
            [x0 + 3.0, 3.0, x0, 3.0],
            [x0, 3.0, x0, 0.0],
        ]
        boxes += [[x0 + 0.6, 0.6, x0 + 0.9, 0.9], [x0 + 2.0, 1.8, x0 + 2.3, 2.4]]
    boxes.append([2.2, 0.5, 2.5, 0.8])
    return world_from_dict({"wall_thickness": 0.05, "walls": walls, "boxes": boxes, "start": [1.5, 1.5, 0.3]})


def test_global_search_finds_the_true_pose_among_a_look_alike():
    world = twin_rooms()
    grid = rasterize_world(world, 0.05)
    matcher = CorrelativeMatcher(ScoreMap.from_occupancy(grid))
    truth = np.array([1.47, 1.62, 0.3])
    points = scan_points(world, truth, noise=0.01, seed=2)
    found = matcher.search(points, count=3, max_nodes=10**8)
    assert found[0].exhaustive
    assert math.hypot(*(found[0].pose[:2] - truth[:2])) < 0.03
    assert abs(math.remainder(found[0].pose[2] - truth[2], 2 * math.pi)) < math.radians(1.5)
    twin = [m for m in found[1:] if math.hypot(*(m.pose[:2] - truth[:2] - (3.5, 0.0))) < 0.1]
    assert twin and twin[0].score < found[0].score - 0.02
    for a, b in pairwise(found):
        assert a.score >= b.score


def test_global_search_honours_its_budget_and_resumes_to_the_same_answer(pillars):
    world, _, matcher = pillars
    truth = np.array([world.start.x, world.start.y, world.start.theta])
    points = scan_points(world, truth, noise=0.01, seed=3)
    whole = matcher.search(points, count=2, max_nodes=10**9, refine=False)
    search = GlobalSearch(matcher, points, count=2)
    assert search.step(10**9, max_seconds=0.0) == [] and search.nodes == 0 and not search.done
    before, calls = 0, 0
    while not search.done:
        partial = search.step(2_000, refine=False)
        assert search.nodes - before <= 2_000 + 3  # the last expansion may score up to 3 more children
        assert all(not m.exhaustive for m in partial) or search.done
        before, calls = search.nodes, calls + 1
    assert calls > 5 and search.nodes == whole[0].nodes
    assert [m.score for m in partial] == [m.score for m in whole]
    assert np.allclose([m.pose for m in partial], [m.pose for m in whole])
    assert math.hypot(*(whole[0].pose[:2] - truth[:2])) < 0.05


def test_a_windowed_match_in_slices_is_the_match(pillars):
    """WindowMatch, the match spread over calls of bounded work (a loop closure's search over several SLAM updates):
    its answer once done is match's to the digit."""
    world, _, matcher = pillars
    truth = np.array([world.start.x, world.start.y, world.start.theta])
    points = scan_points(world, truth, noise=0.01, seed=2)
    prior = truth - (0.3, -0.25, math.radians(8))
    whole = matcher.match(points, prior, 0.6, math.radians(25))
    search = WindowMatch(matcher, points, prior, 0.6, math.radians(25))
    calls = 0
    while not search.done:
        before = search.nodes
        search.advance(50)
        assert search.nodes - before <= 50 + 3
        calls += 1
    sliced = search.result()
    assert calls > 5 and sliced.nodes == whole.nodes and sliced.exhaustive
    assert sliced.score == whole.score and np.array_equal(sliced.pose, whole.pose)
    assert np.array_equal(sliced.covariance, whole.covariance)


def test_global_search_keeps_to_the_candidate_region(pillars):
    world, grid, matcher = pillars
    truth = np.array([world.start.x, world.start.y, world.start.theta])
    points = scan_points(world, truth, seed=4)
    region = np.zeros(grid.data.shape, dtype=bool)
    row, col = grid.world_to_cell(truth[0], truth[1])
    region[row + 10 : row + 20, col - 5 : col + 5] = True  # 0.5-1 m away from the truth
    found = matcher.search(points, region, count=3, max_nodes=10**8, refine=False, min_separation=0.1)
    for m in found:
        r, c = grid.world_to_cell(m.pose[0], m.pose[1])
        assert region[int(r), int(c)]
    assert found[0].score < matcher.score(points, truth)


def test_covariance_is_long_along_a_corridor():
    world = world_from_dict(
        {"wall_thickness": 0.05, "walls": [[0.0, 0.0, 30.0, 0.0], [0.0, 1.0, 30.0, 1.0]], "start": [15.0, 0.5, 0.0]}
    )
    matcher = CorrelativeMatcher(ScoreMap.from_occupancy(rasterize_world(world, 0.05)))
    points = scan_points(world, (15.0, 0.5, 0.0), seed=5, max_range=3.0)
    found = matcher.match(points, (15.0, 0.5, 0.0), 0.3, 0.1)
    covariance = found.covariance
    assert np.all(np.linalg.eigvalsh(covariance) > 0.0) and np.allclose(covariance, covariance.T)
    assert covariance[0, 0] > 10.0 * covariance[1, 1]


def test_score_map_from_points_peaks_on_the_points_and_pads_around_them():
    points = np.array([[0.0, 0.0], [1.0, 0.5]])
    score = ScoreMap.from_points(points, 0.1, 0.1, 0.3)
    matcher = CorrelativeMatcher(score, levels=1)
    assert matcher.score(points, (0.0, 0.0, 0.0)) == pytest.approx(1.0)
    assert matcher.score(points + [0.35, 0.0], (0.0, 0.0, 0.0)) < 0.05
    assert score.origin[0] <= -0.3 and score.origin[1] <= -0.3
    with pytest.raises(ValueError, match="no finite point to rasterize or cover"):
        ScoreMap.from_points(np.full((3, 2), np.nan), 0.1, 0.1, 0.3)


def test_a_point_clouds_field_is_the_occupancy_field_of_its_cells_within_its_reach():
    """ScoreMap.from_points stamps the field around the points' cells instead of a distance transform of the box:
    the same values cell for cell where they exceed exp(-FIELD_REACH^2 / 2), 0 beyond."""
    points = np.random.default_rng(2).uniform(-3.0, 3.0, (60, 2))
    resolution, sigma, pad = 0.05, 0.05, 0.2
    field = ScoreMap.from_points(points, resolution, sigma, pad)
    low = np.floor((points.min(axis=0) - pad) / resolution) * resolution
    shape = np.ceil((points.max(axis=0) + pad - low) / resolution).astype(int) + 1
    cells = np.floor((points - low) / resolution).astype(int)
    data = np.zeros((shape[1], shape[0]), dtype=np.int8)
    data[cells[:, 1], cells[:, 0]] = 100
    reference = ScoreMap.from_occupancy(OccupancyGrid(data, resolution, (low[0], low[1], 0.0)), sigma=sigma)
    assert field.table.shape == reference.table.shape and field.origin == pytest.approx(reference.origin)
    near = reference.table > math.exp(-0.5 * FIELD_REACH**2) * 1.001
    np.testing.assert_array_equal(field.table[near], reference.table[near])
    assert (field.table[~near] <= math.exp(-0.5 * FIELD_REACH**2)).all() and near.mean() < 0.9


def test_window_scores_cover_the_window_and_agree_with_the_match(pillars):
    world, _, matcher = pillars
    truth = np.array([1.0, 1.2, 0.3])
    points = scan_points(world, truth)
    prior = truth + [0.1, -0.05, 0.05]
    poses, scores = matcher.window_scores(points, prior, 0.2, 0.1)
    assert len(poses) == len(scores) and np.all((scores >= 0.0) & (scores <= 1.0))
    assert np.abs(poses[:, :2] - prior[:2]).max() <= 0.2 + 0.05 and np.abs(poses[:, 2] - prior[2]).max() <= 0.11
    best = poses[np.argmax(scores)]
    match = matcher.match(points, prior, 0.2, 0.1, refine=False)
    assert scores.max() == pytest.approx(match.score)
    assert np.hypot(*(best[:2] - truth[:2])) <= 0.075


@pytest.mark.parametrize("levels", [1, 3])
def test_a_lattices_totals_are_each_poses_total(levels):
    # every pose's integer sum of the table at its points' cells (_node_total, point by point with its bounds), the
    # window crossing the table's edges and two points far off it: the lattice's sums must be the same integers
    rng = np.random.default_rng(levels)
    matcher = CorrelativeMatcher(ScoreMap.from_probability(rng.random((30, 26)), 0.1, (-1.0, -2.0)), levels=levels)
    points = np.vstack([rng.uniform(-1.5, 1.5, (40, 2)), [[500.0, 0.0], [0.0, -800.0]]])
    rows, cols = _cells(points, -2.2, -2.9, np.array([-0.2, 0.0, 0.4]), matcher.origin, matcher.resolution)
    totals = np.full((3, 11, 13), -1, dtype=np.int64)
    _lattice_totals(matcher.pyramid, matcher.pad, rows, cols, totals)
    pyramid, pad = matcher.pyramid, matcher.pad
    expected = [
        [[_node_total(pyramid, 0, pad, rows, cols, a, x, y) for x in range(13)] for y in range(11)] for a in range(3)
    ]
    np.testing.assert_array_equal(totals, expected)
    r, c, (height, width) = rows + pad, cols + pad, pyramid.shape[1:]
    across = (r < height) & (c < width) & (r + 11 > 0) & (c + 13 > 0) & ((r < 0) | (c < 0) | (r + 11 > height))
    assert across.any() and (r >= 0).any()  # points whose window crosses the table's edge, and points within it


def _transformed_points_table(points: np.ndarray, resolution: float, sigma: float, pad: float) -> np.ndarray:
    """from_points' to_points field by a distance transform of the whole box (scipy's nearest occupied cell, ties
    by its choice), exp(-d^2 / (2 sigma^2)) to that cell's points' mean: what the stamped field must equal."""
    from scipy import ndimage

    extent = np.vstack([points, np.zeros((1, 2))])
    low = np.floor((extent.min(axis=0) - pad) / resolution) * resolution
    cols, rows = (np.ceil((extent.max(axis=0) + pad - low) / resolution).astype(int) + 1).tolist()
    cells = np.floor((points - low) / resolution).astype(int)
    flat = cells[:, 1] * cols + cells[:, 0]
    occupied, group = np.unique(flat, return_inverse=True)
    count = np.bincount(group)
    mean_x, mean_y = np.zeros(rows * cols), np.zeros(rows * cols)
    mean_x[occupied] = np.bincount(group, weights=points[:, 0]) / count
    mean_y[occupied] = np.bincount(group, weights=points[:, 1]) / count
    free = np.ones(rows * cols, dtype=bool)
    free[occupied] = False
    _, (near_r, near_c) = ndimage.distance_transform_edt(free.reshape(rows, cols), return_indices=True)
    nearest = near_r * cols + near_c
    dx = (low[0] + (np.arange(cols) + 0.5) * resolution)[None, :] - mean_x[nearest]
    dy = (low[1] + (np.arange(rows) + 0.5) * resolution)[:, None] - mean_y[nearest]
    return np.exp(-0.5 * (dx * dx + dy * dy) / (sigma * sigma)).astype(np.float32)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_field_to_the_points_is_stamped_as_the_distance_transform_gives_it(seed):
    # walls (a corridor, a crossing wall) and clutter: ties between equally near cells
    rng = np.random.default_rng(seed)
    along = rng.uniform(0.0, 6.0, 800)
    cloud = np.vstack(
        [
            np.column_stack([along, 0.01 * rng.normal(size=800)]),
            np.column_stack([along, 1.2 + 0.01 * rng.normal(size=800)]),
            np.column_stack([3.0 + 0.01 * rng.normal(size=300), rng.uniform(-2.0, 2.0, 300)]),
            rng.uniform(-4.0, 8.0, (200, 2)),
        ]
    )
    field = ScoreMap.from_points(cloud, 0.05, 0.075, 2.5, cover=np.zeros((1, 2)), to_points=True)
    expected = _transformed_points_table(cloud, 0.05, 0.075, 2.5)
    assert field.table.shape == expected.shape
    # the same values wherever the field is above exp(-FIELD_REACH^2 / 2); 0 beyond
    near = expected > np.exp(-0.5 * FIELD_REACH**2) * 1.01
    assert near.sum() > 10_000
    assert np.array_equal(field.table[near], expected[near])
    assert np.abs(field.table - expected).max() < 1e-7
