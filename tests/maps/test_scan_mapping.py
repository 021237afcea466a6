"""amr_maps.scan_mapping: a known grid rebuilt from ray-cast scans, growth keeps alignment, NaN/inf, removal."""

import math

import numpy as np
import pytest

from amr_maps.maze_families import generate
from amr_maps.rasterize import rasterize_world
from amr_maps.raycast import NumpyRayCaster
from amr_maps.scan_mapping import LogOddsGrid, map_from_scans
from amr_maps.world import world_from_dict
from amr_util.geometry import compose
from amr_util.scan import ScanData

INCREMENT = 2.0 * math.pi / 360


@pytest.fixture(scope="module")
def room():
    world = world_from_dict(generate("pillars", 3, size=5.0))
    grid = rasterize_world(world, 0.05)
    rng = np.random.default_rng(1)
    free = np.argwhere(grid.free())
    poses = []
    while len(poses) < 40:
        row, col = free[rng.integers(len(free))]
        x, y = grid.cell_to_world(row, col)
        if world.clearance(np.array([[x, y]]))[0] > 0.2:
            poses.append((float(x), float(y), rng.uniform(-math.pi, math.pi)))
    return world, grid, np.array(poses)


def cast(world, sensor, max_range=3.5):
    return NumpyRayCaster(world.faces).cast(sensor[0], sensor[1], sensor[2] - math.pi, INCREMENT, 360, max_range)


def test_map_from_scans_reproduces_the_known_grid(room):
    world, grid, poses = room
    scans = [ScanData(cast(world, pose), -math.pi, INCREMENT, 0.12, 3.5) for pose in poses]
    built = map_from_scans(poses, scans, 0.05, origin=grid.origin[:2])
    xs, ys = grid.cell_to_world(*np.indices(grid.data.shape))
    rows, cols = built.world_to_cell(xs, ys)
    assert np.all(built.inside(rows, cols))  # the built grid holds the whole room, on the same cells
    mapped = built.data[rows, cols]
    walls, free = grid.data == 100, grid.data == 0
    observed = mapped >= 0
    assert (observed & free).sum() > 0.99 * free.sum()  # 40 scans of 3.5 m see the whole 5 m room
    assert ((mapped == 0) & free).sum() > 0.99 * free.sum()
    occupied = mapped >= 65
    assert (occupied & walls).sum() > 0.98 * occupied.sum()  # what the map calls a wall is one
    assert (occupied & walls).sum() > 0.9 * (walls & observed).sum()  # and the walls it saw it calls walls
    assert not observed[grid.data == -1].any() or (observed & (grid.data == -1)).sum() < 0.01 * walls.sum()


def test_growth_keeps_cell_alignment_and_contents():
    grid = LogOddsGrid(0.1, origin=(0.03, -0.07), margin=0.5)
    grid.insert((0.0, 0.0, 0.0), [1.0], [0.0])
    before = grid.probability()
    origin = grid.origin
    hit = (math.floor((1.0 - origin[0]) / 0.1), math.floor((0.0 - origin[1]) / 0.1))
    assert before[hit[1], hit[0]] > 0.6
    grid.insert((20.0, -15.0, 0.0), [2.0], [math.pi / 2])  # far away: the grid grows down and right
    after = grid.probability()
    new = grid.origin
    shift = ((origin[0] - new[0]) / 0.1, (origin[1] - new[1]) / 0.1)
    assert np.allclose(shift, np.round(shift)) and np.allclose(((new[0] - 0.03) / 0.1) % 1.0, 0.0, atol=1e-9)
    c0, r0 = (int(round(v)) for v in shift)
    assert np.array_equal(after[r0 : r0 + before.shape[0], c0 : c0 + before.shape[1]], before)
    assert grid.shape[0] * 0.1 > 15.0 and grid.shape[1] * 0.1 > 20.0


def test_nan_and_infinite_readings():
    grid = LogOddsGrid(0.1, margin=0.0)
    grid.insert((0.0, 0.0, 0.0), [1.0], [0.0])
    reference = grid.log_odds().copy()
    grid.insert((0.0, 0.0, 0.0), [np.nan, -np.inf, np.inf, 0.0], [0.5, 1.0, 1.5, 2.0])  # nothing to learn
    assert np.array_equal(grid.log_odds(), reference)
    grid.insert((0.0, 0.0, 0.0), [np.inf, 5.0], [math.pi / 2, math.pi], max_range_used=2.0)  # clear up to 2 m
    assert grid.origin[1] <= -0.0 and grid.origin[1] + grid.shape[0] * 0.1 >= 2.0  # grown to hold the clearing
    probability = grid.probability()
    assert probability.max() == pytest.approx(1.0 - 1.0 / (1.0 + math.exp(0.85)))  # only the 1 m return
    up = [
        grid.probability()[int(math.floor((y - grid.origin[1]) / 0.1)), int(-grid.origin[0] / 0.1)]
        for y in (0.5, 1.5, 1.95)
    ]
    assert all(p < 0.45 for p in up)
    occupancy = grid.to_occupancy_grid()
    # one free observation is p = 0.40 (between the thresholds: kept as 40), one hit 0.70 (occupied)
    assert (occupancy.data == -1).any() and (occupancy.data == 40).any() and (occupancy.data == 100).sum() == 1
    with pytest.raises(ValueError, match="ranges"):
        grid.insert((0.0, 0.0, 0.0), [1.0, 2.0], [0.0])


def test_removing_a_scan_takes_it_out_exactly(room):
    world, _, poses = room
    grid = LogOddsGrid(0.05)
    grid.insert(poses[0], cast(world, poses[0]), -math.pi + INCREMENT * np.arange(360))
    alone, seen = grid.log_odds().copy(), grid.observed().copy()
    angles = -math.pi + INCREMENT * np.arange(360)
    for pose in poses[1:4]:
        grid.insert(pose, cast(world, pose), angles)
    for pose in poses[1:4]:
        grid.insert(pose, cast(world, pose), angles, sign=-1)
    rows, cols = alone.shape
    assert np.array_equal(grid.observed()[:rows, :cols], seen) and not grid.observed()[rows:, cols:].any()
    assert np.allclose(grid.log_odds()[:rows, :cols], alone, atol=1e-9)


def test_sensor_mount_offset(room):
    world, _, poses = room
    mount = (0.1, -0.05, 0.3)
    scans = []
    for pose in poses[:5]:
        sensor = compose(tuple(pose), mount)
        scans.append(ScanData(cast(world, sensor), -math.pi, INCREMENT, 0.12, 3.5))
    sensors = np.array([compose(tuple(pose), mount) for pose in poses[:5]])
    with_mount = map_from_scans(poses[:5], scans, mount=mount)
    as_sensors = map_from_scans(sensors, scans)
    assert np.array_equal(with_mount.data, as_sensors.data) and with_mount.origin == as_sensors.origin
    assert not np.array_equal(map_from_scans(poses[:5], scans).data, with_mount.data)


def test_probability_clamps_and_unknown_value():
    grid = LogOddsGrid(0.1, l_occ=1.0, clamp=(-2.0, 3.0), margin=0.0)
    for _ in range(10):
        grid.insert((0.0, 0.0, 0.0), [0.55], [0.0])
    probability = grid.probability(unknown=0.3)
    assert probability.max() == pytest.approx(1.0 - 1.0 / (1.0 + math.exp(3.0)))
    assert probability.min() == pytest.approx(1.0 - 1.0 / (1.0 + math.exp(-2.0)))
    empty = LogOddsGrid(0.1)
    assert empty.to_occupancy_grid().data.tolist() == [[-1]]


def test_insert_many_is_insert_one_by_one():
    """insert_many allocates the arrays once at the extent the scans grow the grid to: the same cells, values and
    origin as inserting the scans in turn (each traced from the origin it would have had), through many growths."""
    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(-15, 15, 12), rng.uniform(-15, 15, 12), rng.uniform(-math.pi, math.pi, 12)])
    angles = [np.linspace(-math.pi, math.pi, 180, endpoint=False) for _ in poses]
    ranges = [rng.uniform(0.2, 12.0, 180) for _ in poses]
    for r in ranges:
        r[rng.integers(0, 180, 15)] = np.inf  # no return: cleared up to max_range_used
        r[rng.integers(0, 180, 5)] = np.nan
    limits = [10.0] * len(poses)
    for origin in (None, (0.013, -0.021)):
        one, many = LogOddsGrid(0.05, origin), LogOddsGrid(0.05, origin)
        one.insert(poses[0], ranges[0], angles[0], limits[0])  # a grid with cells already
        many.insert(poses[0], ranges[0], angles[0], limits[0])
        for args in zip(poses[1:], ranges[1:], angles[1:], limits[1:], strict=True):
            one.insert(*args)
        many.insert_many(poses[1:], ranges[1:], angles[1:], limits[1:])
        assert one.origin == many.origin and one.shape == many.shape
        assert np.array_equal(one.log_odds(), many.log_odds()) and np.array_equal(one.observed(), many.observed())
        many.insert_many(poses[1:], ranges[1:], angles[1:], limits[1:], sign=-1)  # taken out exactly, as insert's
        for args in zip(poses[1:], ranges[1:], angles[1:], limits[1:], strict=True):
            one.insert(*args, sign=-1)
        assert np.array_equal(one.log_odds(), many.log_odds()) and np.array_equal(one.observed(), many.observed())
    empty = LogOddsGrid(0.05)
    empty.insert_many(poses, ranges, angles, limits)
    first = LogOddsGrid(0.05)
    for args in zip(poses, ranges, angles, limits, strict=True):
        first.insert(*args)
    assert empty.origin == first.origin and np.array_equal(empty.log_odds(), first.log_odds())
    with pytest.raises(ValueError, match="insert_many"):
        empty.insert_many(poses, ranges[:3], angles, limits)


def test_probability_thresholds_are_the_probabilitys_own():
    """probability_at_least / at_most compare the log odds, the formula only near the level: the same cells as
    probability() compared, on scans' sums, never-observed cells, sums a rounding away from 0 and the clamp."""
    rng = np.random.default_rng(5)
    grid = LogOddsGrid(0.05)
    for _ in range(6):
        angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
        grid.insert(rng.uniform(-1, 1, 3), rng.uniform(0.3, 4.0, 360), angles, 3.0)
    seen = np.argwhere(grid.observed())
    total = grid._sum  # cells at the edges of the formula: a rounding either side of 0, the clamp, a level
    for value, (r, c) in zip(
        [5e-17, -5e-17, 2e-16, -2e-16, 0.0, 1e-10, -1e-10, math.log(0.3 / 0.7), 40.0, -40.0], seen[:10], strict=True
    ):
        total[r, c] = value
    for level in (0.5, 0.3, 0.65, 0.25, 0.999999, 0.0, 1.0):
        for unknown in (0.5, 0.2):
            probability = grid.probability(unknown)
            assert np.array_equal(grid.probability_at_least(level, unknown), probability >= level), level
            assert np.array_equal(grid.probability_at_most(level, unknown), probability <= level), level
