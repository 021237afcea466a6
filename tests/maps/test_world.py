"""Worlds: the shipped files load into sound geometry, malformed ones name the faulty key."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from amr_maps.world import SOURCE_WORLDS, WorldError, load_world, resolve_world_path, world_from_dict, world_search_path
from amr_simulation.physics import Physics

WORLDS = Path(__file__).resolve().parents[2] / "config" / "worlds"
SHIPPED = sorted(p.name for p in WORLDS.glob("*.yaml"))
RADIUS = 0.105  # TurtleBot3 Burger footprint


def polygon_area(polygon: np.ndarray) -> float:
    """Shoelace formula: positive for counter-clockwise vertices."""
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_the_four_required_worlds_ship() -> None:
    assert set(SHIPPED) >= {"outer_corridor.yaml", "inner_maze.yaml", "open_room.yaml", "hard_maze.yaml"}


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_world_loads_with_counter_clockwise_solids(name: str) -> None:
    world = load_world(WORLDS / name)
    assert world.name == Path(name).stem
    assert all(polygon_area(p) > 0.0 for p in world.polygons)
    assert world.faces.shape[1] == 4 and np.all(np.isfinite(world.faces))


def test_seed_start_poses_match_the_launch_file() -> None:
    outer = load_world(WORLDS / "outer_corridor.yaml").start
    inner = load_world(WORLDS / "inner_maze.yaml").start
    assert (outer.x, outer.y) == (1.0, -1.0) and math.isclose(outer.theta, 0.5 * math.pi)
    assert (inner.x, inner.y) == (0.6, -0.6) and math.isclose(inner.theta, -0.5 * math.pi)  # 3 pi / 2 wrapped


def test_wall_is_a_rectangle_extended_by_half_the_thickness() -> None:
    world = world_from_dict({"wall_thickness": 0.1, "walls": [[0.0, 0.0, 2.0, 0.0]], "start": [0, 1, 0]})
    (polygon,) = world.polygons
    np.testing.assert_allclose(polygon, [[-0.05, -0.05], [2.05, -0.05], [2.05, 0.05], [-0.05, 0.05]])


def test_grid_merges_cells_into_boxes_and_outline() -> None:
    world = world_from_dict(
        {
            "grid": {"cell_size": 0.5, "origin": [0.0, 0.0], "rows": ["##.", "##.", "..#"]},
            "start": [0.25, 0.25, 0.0],
        }
    )
    # the 2 x 2 block (top left) is one box, the lone cell (bottom right) another
    boxes = sorted(tuple(np.round(p.min(axis=0), 6)) + tuple(np.round(p.max(axis=0), 6)) for p in world.polygons)
    assert boxes == [(0.0, 0.5, 1.0, 1.5), (1.0, 0.0, 1.5, 0.5)]
    # outline: 4 merged edges per block, each with the solid just on its left
    assert len(world.faces) == 8
    for x1, y1, x2, y2 in world.faces:
        left = np.array([y1 - y2, x2 - x1]) / math.hypot(x2 - x1, y2 - y1)
        probe = np.array([(x1 + x2) / 2, (y1 + y2) / 2]) + 0.01 * left
        assert any(np.all(p.min(axis=0) < probe) and np.all(probe < p.max(axis=0)) for p in world.polygons)


def test_resolve_world_path_finds_shipped_names_and_reports_missing() -> None:
    assert resolve_world_path("open_room.yaml", [WORLDS]) == WORLDS / "open_room.yaml"
    with pytest.raises(WorldError, match="nowhere.yaml"):
        resolve_world_path("nowhere.yaml", [WORLDS])


BASE = {"wall_thickness": 0.02, "walls": [[0.0, 0.0, 1.0, 0.0]], "start": [0.5, 0.5, 0.0]}


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"wall_thickness": 0.0}, "wall_thickness"),
        ({"wall_thickness": None}, "wall_thickness"),
        ({"walls": [[0.0, 0.0, 1.0]]}, "walls[0]"),
        ({"walls": [[0.0, 0.0, 1.0, 0.0], [1, 1, 1, 1]]}, "walls[1]"),
        ({"walls": [[0.0, "a", 1.0, 0.0]]}, "walls[0]"),
        ({"walls": "x"}, "walls"),
        ({"boxes": [[1.0, 0.0, 0.0, 1.0]]}, "boxes[0]"),
        ({"start": [0.0, 0.0]}, "start"),
        ({"start": None}, "start"),
        ({"goal": [1.0, 1.0, -0.1]}, "goal"),
        ({"goal": [1.0, float("nan"), 0.1]}, "goal"),
        ({"grid": {"cell_size": 0.1, "origin": [0, 0], "rows": ["#.", "#"]}}, "grid.rows[1]"),
        ({"grid": {"cell_size": 0.1, "origin": [0, 0], "rows": ["#x"]}}, "grid.rows[0]"),
        ({"grid": {"cell_size": -1.0, "origin": [0, 0], "rows": ["#"]}}, "grid.cell_size"),
        ({"grid": {"cell_size": 0.1, "origin": [0], "rows": ["#"]}}, "grid.origin"),
        ({"grid": {"cell_size": 0.1, "origin": [0, 0], "rows": ["#"], "size": 3}}, "grid.size"),
        ({"wal_thickness": 0.1}, "wal_thickness"),
        ({"name": ""}, "name"),
    ],
)
def test_malformed_world_names_the_key(change: dict, key: str) -> None:
    data = {**BASE, **change}
    if change.get("start", 0) is None:
        del data["start"]
    with pytest.raises(WorldError) as info:
        world_from_dict(data, source="bad.yaml")
    assert str(info.value).startswith(f"bad.yaml: {key}: ")


def test_world_without_solids_is_refused() -> None:
    with pytest.raises(WorldError, match="no solids"):
        world_from_dict({"start": [0, 0, 0]})


def test_file_errors_name_the_file(tmp_path: Path) -> None:
    broken = tmp_path / "broken.yaml"
    broken.write_text("walls: [[0, 0, 1\n")
    with pytest.raises(WorldError, match="broken.yaml: not valid YAML"):
        load_world(broken)
    with pytest.raises(WorldError, match="missing.yaml: cannot read"):
        load_world(tmp_path / "missing.yaml")
    listed = tmp_path / "list.yaml"
    listed.write_text("- 1\n- 2\n")
    with pytest.raises(WorldError, match="list.yaml: a world must be a mapping"):
        load_world(listed)


def reachable_share(world, resolution: float = 0.05) -> float:
    """Share of the footprint-free grid points the robot can reach from its start."""
    physics = Physics(world.polygons, RADIUS)
    xmin, ymin, xmax, ymax = world.bounds
    xs, ys = np.arange(xmin, xmax, resolution), np.arange(ymin, ymax, resolution)
    free = np.array([[physics.clearance(x, y) >= RADIUS for y in ys] for x in xs])
    start = (int(round((world.start.x - xmin) / resolution)), int(round((world.start.y - ymin) / resolution)))
    seen, frontier = {start}, [start]
    while frontier:
        i, j = frontier.pop()
        for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
            if 0 <= a < len(xs) and 0 <= b < len(ys) and free[a, b] and (a, b) not in seen:
                seen.add((a, b))
                frontier.append((a, b))
    return len(seen) / free.sum()


@pytest.mark.parametrize("name", ["inner_maze.yaml", "hard_maze.yaml", "open_room.yaml"])
def test_a_turtlebot_can_reach_all_free_space(name: str) -> None:
    assert reachable_share(load_world(WORLDS / name)) == 1.0


def test_outer_corridor_is_a_ring_closed_by_a_dead_end() -> None:
    world = load_world(WORLDS / "outer_corridor.yaml")
    physics = Physics(world.polygons, RADIUS)
    assert 0.3 < reachable_share(world) < 0.5  # the walled-in centre block is not reachable
    # the dead-end wall separates the start cell from its western neighbour
    assert physics.clearance(0.8, -1.0) < RADIUS
    assert all(physics.clearance(x, y) >= RADIUS for x, y in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (0.6, -1.0)])


def test_set_pose_outside_the_world_bounds_is_refused_naming_them():
    from amr_maps.world import load_world, resolve_world_path
    from amr_simulation.errors import SimulationError
    from amr_simulation.simulator import Simulator

    sim = Simulator(load_world(resolve_world_path("outer_corridor.yaml")))
    with pytest.raises(
        SimulationError, match=r"\(100.000, 0.000\) lies outside the bounds of .*x in \[-4\.\d+, 4\.\d+\]"
    ):
        sim.set_pose(100.0, 0.0, 0.0)
    xmin, ymin, xmax, ymax = sim.bounds
    assert xmin < -1.2 - 3.4 and xmax > 1.2 + 3.4, "the walls' extent plus the LiDAR range"


def test_relative_world_names_look_in_the_package_share_directory_first(monkeypatch):
    monkeypatch.setenv("AMENT_PREFIX_PATH", sys.prefix)
    share = Path(sys.prefix) / "share" / "amr_maps" / "config" / "worlds"
    assert world_search_path()[0] == share
    assert (share / "open_room.yaml").is_file(), "worlds are installed with the package (make setup)"
    monkeypatch.delenv("AMENT_PREFIX_PATH")
    assert world_search_path() == (share, SOURCE_WORLDS), (
        "without an ament prefix, this prefix's share, then the source"
    )
