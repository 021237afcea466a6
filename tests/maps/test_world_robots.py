"""The `robots` list of a world: named robots with starts and goals, each problem named by file, key and value."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from amr_maps.maze_families import FAMILIES, generate
from amr_maps.world import ROBOT_NAME, RobotSpec, WorldError, load_world, world_from_dict
from amr_simulation.physics import Physics

WORLDS = Path(__file__).resolve().parents[2] / "config" / "worlds"
ROOM = {
    "wall_thickness": 0.1,  # inner faces at x = +-1.95, y = +-1.45; a box (pillar) at the centre
    "walls": [[-2.0, -1.5, 2.0, -1.5], [2.0, -1.5, 2.0, 1.5], [2.0, 1.5, -2.0, 1.5], [-2.0, 1.5, -2.0, -1.5]],
    "boxes": [[-0.2, -0.2, 0.2, 0.2]],
}
TWO = [{"name": "r1", "start": [-1.5, -1.0, 0.0], "goal": [1.5, 1.0, 0.15]}, {"name": "r2", "start": [1.5, -1.0, 7.0]}]


def test_a_world_lists_its_robots_in_order_with_starts_and_goals() -> None:
    world = world_from_dict({**ROOM, "robots": TWO})
    r1, r2 = world.robots
    assert (r1.name, r1.start, (r1.goal.x, r1.goal.y, r1.goal.radius)) == ("r1", (-1.5, -1.0, 0.0), (1.5, 1.0, 0.15))
    assert r2.name == "r2" and r2.goal is None and r2.start.theta == pytest.approx(7.0 - 2.0 * math.pi)  # wrapped
    assert world.fleet == world.robots
    assert (world.start, world.goal) == (r1.start, r1.goal)  # readers of one start see the first robot's


@pytest.mark.parametrize("name", sorted(p.name for p in WORLDS.glob("*.yaml")))
def test_a_world_without_the_list_is_one_unnamed_robot(name: str) -> None:
    world = load_world(WORLDS / name)
    assert world.robots == () and world.fleet == (RobotSpec("", world.start, world.goal),)


def test_a_robot_list_loads_from_a_file(tmp_path: Path) -> None:
    path = tmp_path / "pair.yaml"
    path.write_text(yaml.safe_dump({**ROOM, "robots": TWO}))
    assert [robot.name for robot in load_world(path).robots] == ["r1", "r2"]


@pytest.mark.parametrize(
    ("robots", "extra", "key", "problem"),
    [
        ([], {}, "robots", "must be a non-empty list"),
        ("r1", {}, "robots", "must be a non-empty list of robots .*got 'r1'"),
        (["r1"], {}, r"robots\[0\]", r"must be a mapping with name, start, goal \(and optionally priority\), got 'r1'"),
        ([{"name": "r1", "start": [0, 1, 0], "colour": "red"}], {}, r"robots\[0\]\.colour", "unknown key"),
        ([{"start": [0, 1, 0]}], {}, r"robots\[0\]\.name", "is required"),
        ([{"name": "r1"}], {}, r"robots\[0\]\.start", "is required"),
        ([{"name": "1r", "start": [0, 1, 0]}], {}, r"robots\[0\]\.name", "ROS name token .*got '1r'"),
        ([{"name": "r-1", "start": [0, 1, 0]}], {}, r"robots\[0\]\.name", "got 'r-1'"),
        ([{"name": "a/b", "start": [0, 1, 0]}], {}, r"robots\[0\]\.name", "got 'a/b'"),
        ([{"name": "", "start": [0, 1, 0]}], {}, r"robots\[0\]\.name", "got ''"),
        ([{"name": 7, "start": [0, 1, 0]}], {}, r"robots\[0\]\.name", "got 7"),
        (
            TWO + [{"name": "r1", "start": [0, 1, 0]}],
            {},
            r"robots\[2\]\.name",
            "'r1' is already the name of robots\\[0\\]",
        ),
        ([{"name": "r1", "start": [0, 1]}], {}, r"robots\[0\]\.start", r"expected \[x, y, theta\].*got \[0, 1\]"),
        ([{"name": "r1", "start": [0, math.nan, 0]}], {}, r"robots\[0\]\.start", "finite numbers"),
        ([{"name": "r1", "start": [0, 1, 0], "goal": [1, 1, 0]}], {}, r"robots\[0\]\.goal", "radius must be positive"),
        ([{"name": "r1", "start": [0.1, 0.0, 0]}], {}, r"robots\[0\]\.start", r"\(0.1, 0\) lies inside a solid"),
        (
            [{"name": "r1", "start": [0, 1, 0], "goal": [0.0, 1.49, 0.1]}],
            {},
            r"robots\[0\]\.goal",
            "lies inside a solid",
        ),
        (
            [{"name": "r1", "start": [5.0, 1, 0]}],
            {},
            r"robots\[0\]\.start",
            r"\(5, 1\) lies outside the solids' extent",
        ),
        (TWO, {"start": [0, 1, 0]}, "start", "gives each robot its own start and goal"),
        (TWO, {"goal": [0, 1, 0.1]}, "goal", "gives each robot its own start and goal"),
    ],
)
def test_a_bad_robot_list_names_file_key_and_value(robots, extra, key, problem) -> None:
    with pytest.raises(WorldError, match=rf"^fleet\.yaml: {key}: .*{problem}"):
        world_from_dict({**ROOM, **extra, "robots": robots}, source="fleet.yaml")


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet="ab_Z09-/. é", min_size=1, max_size=6))
def test_robot_names_are_what_ros_accepts_as_one_namespace_level(name: str) -> None:
    from rclpy.exceptions import InvalidNamespaceException
    from rclpy.validate_namespace import validate_namespace

    try:
        validate_namespace("/" + name)
        ros_accepts = "/" not in name
    except InvalidNamespaceException:
        ros_accepts = False
    assert bool(ROBOT_NAME.match(name)) == ros_accepts


def test_footprints_are_checked_for_a_radius() -> None:
    world = world_from_dict(
        {
            **ROOM,
            "robots": [
                {"name": "r1", "start": [1.9, 0.0, 0.0]},
                {"name": "r2", "start": [-1.0, 0.0, 0.0]},
                {"name": "r3", "start": [-0.8, 0.0, 0.0]},
            ],
        },
        source="fleet.yaml",
    )
    world.check_footprints(0.04)  # clear of the wall by 0.05, of each other by 0.2
    with pytest.raises(
        WorldError,
        match=r"^fleet\.yaml: robots\[0\]\.start: \[1.9, 0, 0\]: r1 \(radius 0.06 m\) "
        r"overlaps a solid \(clearance 0.050 m\)",
    ):
        world.check_footprints(0.06)
    moved = world_from_dict(
        {**ROOM, "robots": [{"name": "r2", "start": [-1.0, 0.0, 0.0]}, {"name": "r3", "start": [-0.8, 0.0, 0.0]}]},
        source="fleet.yaml",
    )
    with pytest.raises(
        WorldError,
        match=r"robots\[1\]\.start: .*r3 overlaps r2 \(robots\[0\]\): centres 0.200 m "
        r"apart, robots of radius 0.105 m need 0.210 m",
    ):
        moved.check_footprints(0.105)


@pytest.mark.parametrize("family", FAMILIES)
def test_clearance_agrees_with_pymunk_in_generated_worlds(family: str) -> None:
    world = world_from_dict(generate(family, seed=5))
    physics = Physics(world.polygons, 10.0)  # a big radius: pymunk reports distances up to it
    xmin, ymin, xmax, ymax = world.bounds
    points = np.random.default_rng(FAMILIES.index(family)).uniform((xmin, ymin), (xmax, ymax), size=(300, 2))
    ours = world.clearance(points)
    reference = np.array([physics.clearance(x, y) for x, y in points])
    outside = reference > 1e-9
    np.testing.assert_allclose(ours[outside], reference[outside], atol=1e-9)
    assert np.all(ours[reference < -1e-9] < 0.0)  # inside a solid: negative (depths differ where solids overlap)
