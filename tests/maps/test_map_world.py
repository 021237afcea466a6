"""Maps as worlds: world -> map_server YAML + PGM -> world drives exactly like the original."""

import dataclasses

import numpy as np
import pytest
import yaml

from amr_maps.map_io import save_map
from amr_maps.map_world import load_map_world, most_open_pose, world_from_grid
from amr_maps.occupancy_grid import MapError, OccupancyGrid
from amr_maps.rasterize import rasterize_world
from amr_maps.world import SOURCE_WORLDS, WorldError, load_world, world_from_dict
from amr_simulation.simulator import Simulator

SHIPPED_WORLDS = sorted(SOURCE_WORLDS.glob("*.yaml"))
LATTICE = 0.005  # every shipped world's coordinates are multiples of it from their lower-left corner


def recorded_drive(seed, steps):
    """Straight runs into walls, backing off and turning, mixed with random arcs: many collisions."""
    rng = np.random.default_rng(seed)
    commands = []
    while len(commands) < steps:
        if rng.random() < 0.5:
            commands += [(0.2, 0.0)] * 100 + [(-0.1, 0.0)] * 10
        commands += [(float(rng.uniform(0.0, 0.22)), float(rng.uniform(-2.0, 2.0)))] * int(rng.integers(5, 30))
    return commands[:steps]


def run(world, commands):
    simulator = Simulator(dataclasses.replace(world, goal=None))  # no goal to stop the drive
    poses, contacts, scans = [], [], []
    for v, w in commands:
        simulator.step(v, w)
        poses.append(tuple(simulator.pose))
        contacts.append(simulator.in_contact)
        scans.append(np.array(simulator.ranges))
    return np.array(poses), np.array(contacts), simulator.collisions, np.array(scans)


def assert_same_run(original, copy):
    poses, contacts, collisions, scans = original
    assert collisions > 3, "the drive must actually hit walls"
    assert copy[2] == collisions
    assert np.array_equal(copy[1], contacts)
    np.testing.assert_allclose(copy[0], poses, rtol=0, atol=1e-9)
    assert np.array_equal(np.isinf(copy[3]), np.isinf(scans))
    finite = np.isfinite(scans)
    np.testing.assert_allclose(copy[3][finite], scans[finite], rtol=0, atol=1e-9)


@pytest.mark.parametrize("path", SHIPPED_WORLDS, ids=lambda p: p.stem)
def test_every_shipped_world_round_trips_through_map_server_files(tmp_path, path):
    world = load_world(path)
    save_map(rasterize_world(world, LATTICE), tmp_path / "maps" / world.name)
    start, goal = list(world.start), world.goal
    (tmp_path / "copy.yaml").write_text(
        yaml.safe_dump(
            {
                "map": f"maps/{world.name}.yaml",
                "start": [float(v) for v in start],
                "goal": None if goal is None else [goal.x, goal.y, goal.radius],
            }
        )
    )
    copy = load_world(tmp_path / "copy.yaml")
    assert copy.goal == world.goal
    commands = recorded_drive(seed=len(world.name), steps=1200)
    assert_same_run(run(world, commands), run(copy, commands))


@pytest.mark.parametrize("seed", range(3))
def test_generated_lattice_worlds_keep_their_solids_exactly(tmp_path, seed):
    """Crossing and touching walls decompose into other boxes than the file's, so pymunk may resolve a
    corner contact differently (README: order of solids); the solids themselves must be the same."""
    rng = np.random.default_rng(100 + seed)
    size = int(rng.integers(30, 50)) * 0.05
    walls = [[0, 0, size, 0], [size, 0, size, size], [size, size, 0, size], [0, size, 0, 0]]
    for _ in range(int(rng.integers(2, 6))):  # axis-aligned inner walls on the 0.05 m lattice
        x, y = rng.integers(4, int(size / 0.05) - 4, 2) * 0.05
        length = rng.integers(4, 12) * 0.05
        walls.append([x, y, x + length, y] if rng.random() < 0.5 else [x, y, x, y + length])
    boxes = [[1.0, 0.2, 1.3, 0.35]]
    world = world_from_dict({"wall_thickness": 0.02, "walls": walls, "boxes": boxes, "start": [0.15, 0.15, 0.7]})
    copy = load_map_world(save_map(rasterize_world(world, 0.01), tmp_path / "generated"), start=(0.15, 0.15, 0.7))
    original, rebuilt = Simulator(world), Simulator(copy)
    points = rng.uniform(-0.1, size + 0.1, (300, 2))
    clearance = np.array([[sim._physics.clearance(x, y) for x, y in points] for sim in (original, rebuilt)])
    outside = clearance[0] >= 0.0  # inside a solid the depth depends on which box is nearest
    np.testing.assert_allclose(clearance[1][outside], clearance[0][outside], rtol=0, atol=1e-9)
    assert np.all(clearance[1][~outside] < 0.0)
    scanned = 0
    for (x, y), room in zip(points, clearance[0], strict=True):
        if room >= original.config.robot.radius and 0 < x < size and 0 < y < size:
            scans = []
            for sim in (original, rebuilt):
                sim.set_pose(x, y, 0.3)
                scans.append(np.where(np.isinf(sim.ranges), -1.0, sim.ranges))
            np.testing.assert_allclose(scans[1], scans[0], rtol=0, atol=1e-9)
            scanned += 1
    assert scanned > 20


@pytest.mark.parametrize("seed", range(3))
def test_off_lattice_worlds_rasterize_back_to_the_same_grid(seed):
    rng = np.random.default_rng(seed)
    walls = [[float(v) for v in rng.uniform(-2, 2, 4)] for _ in range(6)]
    world = world_from_dict({"wall_thickness": 0.03, "walls": walls, "start": [5, 5, 0]})
    grid = rasterize_world(world, 0.05)
    copy = world_from_grid(grid, start=(0.0, 0.0, 0.0))
    again = rasterize_world(copy, 0.05, margin=0.0)
    (row, col) = grid.world_to_cell(*np.array(again.origin[:2]) + 0.5 * again.resolution)
    assert np.array_equal(grid.occupied()[row : row + again.height, col : col + again.width], again.occupied())


def test_a_bare_map_starts_at_its_most_open_cell(tmp_path):
    data = np.zeros((20, 30), np.int8)
    data[[0, -1], :] = 100
    data[:, [0, -1]] = 100
    data[:, 8] = 100  # a wall leaving a narrow room on the left
    data[5:8, 20:24] = -1
    yaml_path = save_map(OccupancyGrid(data, 0.1, (1.0, -2.0, 0.0)), tmp_path / "room")
    world = load_map_world(yaml_path)
    assert world.name == "room" and str(yaml_path) in world.source
    grid = OccupancyGrid(data, 0.1, (1.0, -2.0, 0.0))
    free_rows, free_cols = np.nonzero(data == 0)
    blocked_rows, blocked_cols = np.nonzero(data != 0)
    distance = np.hypot(free_rows[:, None] - blocked_rows, free_cols[:, None] - blocked_cols).min(axis=1)
    row, col = grid.world_to_cell(world.start.x, world.start.y)
    assert data[row, col] == 0 and col > 8  # in the big room
    assert distance[(free_rows == row) & (free_cols == col)][0] == distance.max()  # brute force clearance
    Simulator(world)  # the start is clear of the walls
    with pytest.raises(MapError, match="no free cell"):
        most_open_pose(OccupancyGrid(np.full((3, 3), 100, np.int8), 0.1))
    with pytest.raises(MapError, match="no occupied cell"):
        world_from_grid(OccupancyGrid(np.zeros((3, 3), np.int8), 0.1))


def test_world_files_naming_bad_maps_are_refused_by_key(tmp_path):
    save_map(OccupancyGrid(np.full((4, 4), 100, np.int8), 0.1), tmp_path / "lab")
    with pytest.raises(WorldError, match="looks like a map_server map"):
        load_world(tmp_path / "lab.yaml")
    (tmp_path / "w.yaml").write_text("map: nowhere.yaml\nstart: [0, 0, 0]\n")
    with pytest.raises(WorldError, match=r"w\.yaml: map: .*nowhere\.yaml"):
        load_world(tmp_path / "w.yaml")
    (tmp_path / "w.yaml").write_text("map: 3\nstart: [0, 0, 0]\n")
    with pytest.raises(WorldError, match=r"w\.yaml: map: must be"):
        load_world(tmp_path / "w.yaml")
