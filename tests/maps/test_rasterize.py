"""rasterize_world: any-overlap occupancy checked against exact polygon clipping, thin walls, unknown outside."""

import math

import numpy as np
import pytest

from amr_maps.occupancy_grid import FREE, OCCUPIED, UNKNOWN, MapError
from amr_maps.rasterize import rasterize_world
from amr_maps.world import SOURCE_WORLDS, load_world, world_from_dict

SHIPPED_WORLDS = sorted(SOURCE_WORLDS.glob("*.yaml"))


def clipped_area(polygon, x0, y0, x1, y1):
    """Area of a convex polygon clipped to the box (Sutherland-Hodgman): the reference overlap."""
    points = [tuple(p) for p in polygon]
    for axis, bound, keep_above in ((0, x0, True), (0, x1, False), (1, y0, True), (1, y1, False)):

        def inside(p, axis=axis, bound=bound, keep_above=keep_above):
            return p[axis] >= bound if keep_above else p[axis] <= bound

        result = []
        for i, current in enumerate(points):
            previous = points[i - 1]
            if inside(current) != inside(previous):
                t = (bound - previous[axis]) / (current[axis] - previous[axis])
                result.append(tuple(previous[k] + t * (current[k] - previous[k]) for k in (0, 1)))
            if inside(current):
                result.append(current)
        points = result
        if not points:
            return 0.0
    xs, ys = np.array(points).T
    return 0.5 * abs(np.dot(xs, np.roll(ys, -1)) - np.dot(ys, np.roll(xs, -1)))


def random_world(rng):
    """A few rotated boxes and thin walls at random angles, inside a closed square of walls."""
    walls = [[-2, -2, 2, -2], [2, -2, 2, 2], [2, 2, -2, 2], [-2, 2, -2, -2]]
    for _ in range(rng.integers(2, 6)):
        x, y = rng.uniform(-1.5, 1.5, 2)
        angle, length = rng.uniform(0, math.pi), rng.uniform(0.1, 1.0)
        walls.append([x, y, x + length * math.cos(angle), y + length * math.sin(angle)])
    boxes = []
    for _ in range(rng.integers(0, 3)):
        x, y = rng.uniform(-1.5, 1.2, 2)
        boxes.append([x, y, x + rng.uniform(0.01, 0.3), y + rng.uniform(0.01, 0.3)])
    return world_from_dict(
        {
            "wall_thickness": float(rng.choice([0.01, 0.02, 0.05])),
            "walls": walls,
            "boxes": boxes,
            "start": [1.9, 1.9, 0.0],
        }
    )


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("resolution", [0.02, 0.05, 0.13])
def test_a_cell_is_occupied_exactly_where_a_solid_overlaps_it(seed, resolution):
    world = random_world(np.random.default_rng(seed))
    grid = rasterize_world(world, resolution)
    expected = np.zeros(grid.data.shape, dtype=bool)
    for polygon in world.polygons:  # a cell beyond a solid's bounding box (plus one cell) cannot overlap it
        row0, col0 = grid.world_to_cell(*polygon.min(axis=0))
        row1, col1 = grid.world_to_cell(*polygon.max(axis=0))
        for row in range(max(0, row0 - 1), min(grid.height, row1 + 2)):
            for col in range(max(0, col0 - 1), min(grid.width, col1 + 2)):
                x0, y0 = grid.origin[0] + col * resolution, grid.origin[1] + row * resolution
                box = (x0, y0, x0 + resolution, y0 + resolution)
                expected[row, col] |= clipped_area(polygon, *box) > 1e-9 * resolution**2
    assert np.array_equal(grid.data == OCCUPIED, expected)


@pytest.mark.parametrize("resolution", [0.02, 0.05, 0.1])
@pytest.mark.parametrize("angle", [0.0, 0.3, math.pi / 4, 1.2])
def test_thin_walls_leave_no_gap_along_their_length(resolution, angle):
    x1, y1 = 0.02, 0.03
    x2, y2 = x1 + 1.5 * math.cos(angle), y1 + 1.5 * math.sin(angle)
    world = world_from_dict({"wall_thickness": 0.02, "walls": [[x1, y1, x2, y2]], "start": [5, 5, 0]})
    grid = rasterize_world(world, resolution)
    t = np.linspace(0.0, 1.0, 2000)
    row, col = grid.world_to_cell(x1 + t * (x2 - x1), y1 + t * (y2 - y1))
    assert np.all(grid.data[row, col] == OCCUPIED)


def test_solids_on_the_cell_lattice_fill_their_cells_and_no_neighbour():
    world = world_from_dict({"boxes": [[0.0, 0.0, 0.1, 0.1], [0.3, 0.0, 0.4, 0.2]], "start": [5, 5, 0]})
    grid = rasterize_world(world, 0.05, margin=0.0)
    assert grid.origin == (0.0, 0.0, 0.0) and (grid.width, grid.height) == (8, 4)
    expected = np.zeros((4, 8), dtype=bool)
    expected[0:2, 0:2] = True
    expected[0:4, 6:8] = True
    assert np.array_equal(grid.occupied(), expected)


def test_an_ascii_grid_world_comes_back_cell_for_cell():
    world = load_world(SOURCE_WORLDS / "hard_maze.yaml")
    rows = [r for r in (SOURCE_WORLDS / "hard_maze.yaml").read_text().splitlines() if r.strip().startswith('- "')]
    solid = np.array([[c == "#" for c in r.strip()[3:-1]] for r in reversed(rows)])
    grid = rasterize_world(world, 0.1, margin=0.2)
    assert grid.origin[:2] == pytest.approx((-2.25, -2.25))
    assert np.array_equal(grid.occupied()[2:-2, 2:-2], solid)
    fine = rasterize_world(world, 0.05, margin=0.0)
    assert np.array_equal(fine.occupied(), np.kron(solid, np.ones((2, 2), dtype=bool)))


@pytest.mark.parametrize("path", SHIPPED_WORLDS, ids=lambda p: p.stem)
def test_outside_the_outer_walls_is_unknown_and_the_start_is_free(path):
    world = load_world(path)
    grid = rasterize_world(world, 0.05)
    row, col = grid.world_to_cell(world.start.x, world.start.y)
    assert grid.data[row, col] == FREE
    assert np.all(grid.data[0] == UNKNOWN) and np.all(grid.data[:, -1] == UNKNOWN)
    xmin, ymin, xmax, ymax = world.bounds
    inner_row, inner_col = grid.world_to_cell(0.5 * (xmin + xmax), ymin + 0.001)
    assert grid.data[inner_row, inner_col] == OCCUPIED  # the outer wall itself


def test_an_open_world_keeps_its_inside_free_and_only_the_margin_unknown():
    walls = [[-1, -1, 1, -1], [1, -1, 1, 1], [1, 1, -1, 1], [-1, 1, -1, 0.2]]  # gap in the west wall
    world = world_from_dict({"wall_thickness": 0.02, "walls": walls, "start": [0, 0, 0]})
    grid = rasterize_world(world, 0.05, margin=0.1)
    assert np.all(grid.data[2:-2, 2:-2] != UNKNOWN)
    assert np.all(grid.data[:2] == UNKNOWN) and np.all(grid.data[:, :2] == UNKNOWN)
    closed = world_from_dict({"wall_thickness": 0.02, "walls": walls + [[-1, 0.2, -1, -1]], "start": [0, 0, 0]})
    outside = rasterize_world(closed, 0.05, margin=0.1).data == UNKNOWN
    assert outside.sum() == (grid.data == UNKNOWN).sum()


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"resolution": 0.0}, "resolution"),
        ({"resolution": float("nan")}, "resolution"),
        ({"margin": -0.1}, "margin"),
        ({"resolution": "0.05"}, "resolution"),
    ],
)
def test_bad_arguments_are_refused_by_name(kwargs, words):
    world = load_world(SHIPPED_WORLDS[0])
    with pytest.raises(MapError, match=words):
        rasterize_world(world, **kwargs)
