"""Fleets: robots collide with walls and each other, see each other but not themselves, draw their own noise."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pymunk
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from support.simulation import WORLDS, make_config

from amr_maps.maze_families import FAMILIES, generate
from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import World, load_world, world_from_dict
from amr_simulation.config import RobotConfig
from amr_simulation.errors import SimulationError
from amr_simulation.fleet import Fleet
from amr_simulation.raycast import PymunkRayCaster, cast_discs
from amr_simulation.simulator import Simulator
from amr_util.parameter_spec import ConfigError

RADIUS = 0.105
SENSOR_BACK = 0.032  # the LiDAR sits 3.2 cm behind the axle
AHEAD, LEFT, BEHIND, RIGHT = 0, 60, 120, 180  # beam indices of 240 over 360 deg
ROOM = {
    "wall_thickness": 0.1,  # inner faces at x = +-1.95, y = +-1.45
    "walls": [[-2.0, -1.5, 2.0, -1.5], [2.0, -1.5, 2.0, 1.5], [2.0, 1.5, -2.0, 1.5], [-2.0, 1.5, -2.0, -1.5]],
}


def room(*robots: tuple) -> World:
    """The room with robots (name, [x, y, theta]) or (name, start, goal)."""
    entries = [{"name": r[0], "start": list(r[1]), **({"goal": list(r[2])} if len(r) > 2 else {})} for r in robots]
    return world_from_dict({**ROOM, "robots": entries}, source="room.yaml")


def face_to_face(gap: float = 2.0) -> World:
    """r1 at x = -gap / 2 facing +x, r2 at +gap / 2 facing -x."""
    return room(("r1", (-gap / 2, 0.0, 0.0)), ("r2", (gap / 2, 0.0, math.pi)))


def scatter(world: World, count: int, rng: np.random.Generator) -> list[list[float]]:
    """Poses of `count` robots that touch neither a solid nor each other (1 cm to spare)."""
    xmin, ymin, xmax, ymax = world.bounds
    candidates = rng.uniform((xmin, ymin), (xmax, ymax), size=(4000, 2))
    candidates = candidates[world.clearance(candidates) >= RADIUS + 0.01]
    poses: list[list[float]] = []
    for x, y in candidates:
        if all(math.hypot(x - p[0], y - p[1]) > 2 * RADIUS + 0.01 for p in poses):
            poses.append([float(x), float(y), float(rng.uniform(-math.pi, math.pi))])
            if len(poses) == count:
                return poses
    raise AssertionError(f"no room for {count} robots in {world.name}")


def generated_fleet(family: str, seed: int, count: int, rng: np.random.Generator) -> World:
    """A generated maze of the family with `count` robots at scattered free poses instead of its start."""
    data = {key: value for key, value in generate(family, seed).items() if key not in ("start", "goal")}
    poses = scatter(world_from_dict({**data, "start": [0.0, 0.0, 0.0]}), count, rng)
    return world_from_dict({**data, "robots": [{"name": f"r{i}", "start": pose} for i, pose in enumerate(poses)]})


# -- sensing ---------------------------------------------------------------------------------


def test_a_lidar_sees_the_other_robot_and_not_itself() -> None:
    fleet = Fleet(face_to_face(2.0), make_config())
    r1, r2 = fleet.robots
    # r1's sensor at x = -1.032 looks at r2's disc, whose near side is at x = 1 - 0.105
    assert r1.ranges[AHEAD] == pytest.approx(2.0 - RADIUS + SENSOR_BACK)
    assert r2.ranges[AHEAD] == pytest.approx(2.0 - RADIUS + SENSOR_BACK)
    # behind, each sees the wall, not its own body (which surrounds the sensor)
    assert r1.ranges[BEHIND] == pytest.approx(1.95 - 1.0 - SENSOR_BACK)
    assert r1.ranges[LEFT] == pytest.approx(1.45)
    # the disc spans 2 asin(r / d) of the fan, about 5.9 deg: the beams of 1.5 deg within it changed, no other
    alone = Fleet(room(("r1", (-1.0, 0.0, 0.0))), make_config()).robots[0]
    seen = np.flatnonzero(np.asarray(r1.ranges) != np.asarray(alone.ranges))
    width = 2.0 * math.asin(RADIUS / (2.0 + SENSOR_BACK)) / (2.0 * math.pi / 240)
    assert len(seen) in (math.floor(width), math.ceil(width))
    assert set(seen) <= {237, 238, 239, 0, 1, 2, 3}
    assert np.all(np.asarray(r1.ranges)[seen] < np.asarray(alone.ranges)[seen])


def test_a_robot_alone_sees_what_the_one_robot_simulator_sees() -> None:
    alone = Fleet(room(("r1", (-1.0, 0.5, 0.3))), make_config())
    single = Simulator(world_from_dict({**ROOM, "start": [-1.0, 0.5, 0.3]}), make_config())
    np.testing.assert_array_equal(alone.robots[0].ranges, single.ranges)


@pytest.mark.parametrize("family", FAMILIES)
def test_numpy_and_pymunk_casters_agree_with_robots_in_generated_worlds(family: str) -> None:
    world = generated_fleet(family, 3, 6, np.random.default_rng(FAMILIES.index(family)))
    rng = np.random.default_rng(0)
    fleets = [Fleet(world, make_config(lidar={"method": method})) for method in ("numpy", "pymunk")]
    for _ in range(25):  # they see each other move, and the pymunk caster is the reference
        commands = [(0.15, w) for w in rng.uniform(-1.0, 1.0, 6)]
        for fleet in fleets:
            fleet.step(commands)
    for fast, reference in zip(*(fleet.robots for fleet in fleets), strict=True):
        fast, reference = np.asarray(fast.ranges), np.asarray(reference.ranges)
        assert np.array_equal(np.isinf(fast), np.isinf(reference))
        finite = np.isfinite(reference)
        np.testing.assert_allclose(fast[finite], reference[finite], atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(
    discs=st.lists(st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0)), min_size=1, max_size=8),
    origin=st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0)),
    phi0=st.floats(-math.pi, math.pi),
    beams=st.integers(1, 400),
    fov=st.floats(0.5, 2.0 * math.pi),
    radius=st.floats(0.02, 0.5),
)
def test_disc_hits_match_pymunk_segment_queries(discs, origin, phi0, beams, fov, radius) -> None:
    space = pymunk.Space()
    for centre in discs:
        shape = pymunk.Circle(space.static_body, radius, centre)
        space.add(shape)
    assume(all(math.hypot(origin[0] - x, origin[1] - y) > radius + 1e-3 for x, y in discs))
    increment = fov / beams
    ranges = np.full((1, beams), np.inf)
    cast_discs(
        ranges,
        np.array([origin[0]]),
        np.array([origin[1]]),
        np.array([phi0]),
        increment,
        3.0,
        np.array(discs),
        radius,
        np.array([-1]),
    )
    reference = PymunkRayCaster(space, pymunk.ShapeFilter()).cast(*origin, phi0, increment, beams, 3.0)
    fast = ranges[0]
    fast[fast > 3.0] = np.inf
    # a beam grazing a disc may hit it in one and miss in the other: compare where both agree it is not tangent
    tangent = np.zeros(beams, dtype=bool)
    for x, y in discs:
        angle = phi0 + increment * np.arange(beams) - math.atan2(y - origin[1], x - origin[0])
        miss = np.abs(math.hypot(x - origin[0], y - origin[1]) * np.sin(angle)) - radius
        tangent |= np.abs(miss) < 1e-6
    assert np.array_equal(np.isinf(fast)[~tangent], np.isinf(reference)[~tangent])
    finite = np.isfinite(reference) & ~tangent
    np.testing.assert_allclose(fast[finite], reference[finite], atol=1e-7)


def test_a_sensor_inside_a_disc_reads_zero_on_every_beam() -> None:
    ranges = np.full((2, 240), np.inf)
    cast_discs(
        ranges,
        np.array([0.0, 5.0]),
        np.array([0.0, 5.0]),
        np.zeros(2),
        2.0 * math.pi / 240,
        3.5,
        np.array([[0.05, 0.0]]),
        RADIUS,
        np.array([-1, -1]),
    )
    assert np.all(ranges[0] == 0.0) and np.all(np.isinf(ranges[1]))


@settings(max_examples=40, deadline=None)
@given(
    origins=st.lists(
        st.tuples(st.floats(-2.5, 2.5), st.floats(-2.5, 2.5), st.floats(-4.0, 4.0)), min_size=1, max_size=7
    ),
    beams=st.integers(1, 500),
    fov=st.floats(0.1, 2.0 * math.pi),
    max_range=st.floats(0.3, 6.0),
    name=st.sampled_from(sorted(p.name for p in WORLDS.glob("*.yaml"))),
)
def test_many_fans_at_once_are_bit_for_bit_the_single_casts(origins, beams, fov, max_range, name) -> None:
    caster = NumpyRayCaster(load_world(WORLDS / name).faces)
    x, y, phi0 = (np.array(column) for column in zip(*origins, strict=True))
    many = caster.cast_many(x, y, phi0, fov / beams, beams, max_range)
    for row, (px, py, start) in zip(many, origins, strict=True):
        assert np.array_equal(row, caster.cast(px, py, start, fov / beams, beams, max_range))


# -- motion and contacts ---------------------------------------------------------------------


def test_robots_driving_head_on_stop_at_each_other_and_count_one_robot_collision_each() -> None:
    fleet = Fleet(face_to_face(2.0), make_config())
    for _ in range(200):
        fleet.step({"r1": (0.2, 0.0), "r2": (0.2, 0.0)})
        r1, r2 = fleet.robots
        assert r2.pose.x - r1.pose.x >= 2 * RADIUS - 0.011  # at most one substep of travel inside each other
    assert r2.pose.x - r1.pose.x == pytest.approx(2 * RADIUS, abs=0.002)
    for robot, other in ((r1, "r2"), (r2, "r1")):
        assert robot.collisions == 1 and robot.robot_collisions == {other: 1} and robot.wall_collisions == 0
        assert robot.in_contact


def test_a_robot_cannot_push_another() -> None:
    fleet = Fleet(face_to_face(0.6), make_config())
    for _ in range(100):
        fleet.step([(0.22, 0.0), (0.0, 0.0)])
    r1, r2 = fleet.robots
    assert r2.pose.x == pytest.approx(0.3, abs=0.002) and r2.pose.y == pytest.approx(0.0, abs=1e-9)
    assert r1.pose.x == pytest.approx(0.3 - 2 * RADIUS, abs=0.002)
    assert r2.collisions == 1 and r2.robot_collisions == {"r1": 1}  # it was hit: a contact all the same


def test_wall_and_robot_collisions_are_counted_apart() -> None:
    # r1 drives into the east wall; r2 and r3 meet in the middle; r4 stays clear
    world = room(
        ("r1", (1.5, 1.0, 0.0)), ("r2", (-1.0, -0.5, 0.0)), ("r3", (-0.4, -0.5, math.pi)), ("r4", (-1.5, 1.0, 0.0))
    )
    fleet = Fleet(world, make_config())
    for _ in range(150):
        fleet.step([(0.2, 0.0), (0.1, 0.0), (0.1, 0.0), (0.0, 0.5)])
    r1, r2, r3, r4 = fleet.robots
    assert (r1.collisions, r1.wall_collisions, r1.robot_collisions) == (1, 1, {})
    assert (r2.collisions, r2.wall_collisions, r2.robot_collisions) == (1, 0, {"r3": 1})
    assert (r3.collisions, r3.wall_collisions, r3.robot_collisions) == (1, 0, {"r2": 1})
    assert (r4.collisions, r4.in_contact) == (0, False)


@pytest.mark.parametrize("family", FAMILIES)
def test_crowds_never_pass_through_walls_or_each_other(family: str) -> None:
    rng = np.random.default_rng(FAMILIES.index(family) + 10)
    fleet = Fleet(generated_fleet(family, 7, 8, rng), make_config())
    physics = fleet._physics
    for _ in range(300):
        fleet.step([(0.22, w) for w in rng.uniform(-2.0, 2.0, len(fleet))])
        centres = np.array([robot.pose[:2] for robot in fleet.robots])
        gaps = np.hypot(*(centres[:, None, :] - centres[None, :, :]).transpose(2, 0, 1))
        assert gaps[np.triu_indices(len(fleet), 1)].min() >= 2 * RADIUS - 0.012
        assert min(physics.clearance(x, y) for x, y in centres) >= RADIUS - 0.012
    assert sum(robot.collisions for robot in fleet.robots) > 0  # they did meet something


# -- streams, goals, control ------------------------------------------------------------------


def test_each_robot_has_its_own_noise_kept_when_the_list_is_reordered() -> None:
    config = make_config(lidar={"noise_std": 0.01}, encoders={"noise": 0.02})
    a = Fleet(room(("r1", (-1.0, 0.0, 0.0)), ("r2", (1.0, 0.0, math.pi))), config)
    b = Fleet(room(("r2", (1.0, 0.0, math.pi)), ("r1", (-1.0, 0.0, 0.0))), config)
    for _ in range(5):
        a.step({"r1": (0.1, 0.2), "r2": (0.1, -0.2)})
        b.step({"r1": (0.1, 0.2), "r2": (0.1, -0.2)})
    for name in ("r1", "r2"):
        assert a.robot(name).encoder_increments == b.robot(name).encoder_increments
        np.testing.assert_array_equal(a.robot(name).ranges, b.robot(name).ranges)
    assert a.robot("r1").encoder_increments != a.robot("r2").encoder_increments  # not the same stream
    other_seed = Fleet(a.world, dataclasses.replace(config, seed=1))
    other_seed.step({"r1": (0.1, 0.2), "r2": (0.1, -0.2)})
    b.reset()
    b.step({"r1": (0.1, 0.2), "r2": (0.1, -0.2)})
    assert other_seed.robot("r1").encoder_increments != b.robot("r1").encoder_increments


def test_each_robot_stops_at_its_own_goal() -> None:
    world = room(("r1", (-1.0, 0.0, 0.0), (-0.5, 0.0, 0.1)), ("r2", (1.0, 1.0, math.pi)))
    fleet = Fleet(world, make_config())
    for _ in range(60):
        fleet.step([(0.2, 0.0), (0.2, 0.0)])
    r1, r2 = fleet.robots
    assert r1.goal_reached and r1.pose.x == pytest.approx(-0.6, abs=0.011)
    assert not r2.goal_reached and r2.pose.x == pytest.approx(1.0 - 0.2 * 3.0, abs=1e-6)


def test_bad_commands_name_the_robot_and_do_not_step() -> None:
    fleet = Fleet(face_to_face(), make_config())
    for commands, message in [
        ({"r1": (0.1, 0.0)}, "missing \\['r2'\\]"),
        ([(0.1, 0.0)], "1 commands for 2 robots"),
        ({"r1": (0.0, 0.0), "r2": (0.0, 0.0), "r3": (0.0, 0.0)}, "unknown \\['r3'\\]"),
        ([(0.1, 0.0), (math.nan, 0.0)], "robot 'r2' must be finite"),
        ([(0.1, 0.0), "fast"], "robot 'r2' must be finite"),
    ]:
        with pytest.raises(SimulationError, match=message):
            fleet.step(commands)
    assert fleet.steps == 0 and fleet.robots[0].pose == (-1.0, 0.0, 0.0)


def test_set_pose_refuses_another_robots_place_and_unknown_robots() -> None:
    fleet = Fleet(face_to_face(), make_config())
    with pytest.raises(SimulationError, match="robot 'r2' .* overlaps robot 'r1'"):
        fleet.set_pose(-0.85, 0.05, 0.0, robot="r2")
    with pytest.raises(SimulationError, match="overlaps a wall"):
        fleet.set_pose(1.9, 0.0, 0.0, robot=1)
    with pytest.raises(SimulationError, match="no robot named 'r9'"):
        fleet.set_pose(0.0, 0.0, 0.0, robot="r9")
    with pytest.raises(SimulationError, match="no robot 2"):
        fleet.robot(2)
    fleet.set_pose(0.0, 1.0, 0.5, robot="r2")
    assert fleet.robot("r2").pose == (0.0, 1.0, 0.5) and fleet.robot("r2").odom_pose == (0.0, 1.0, 0.5)
    # r1 now looks down the middle of the room: r2 has left its beam
    fleet.step([(0.0, 0.0), (0.0, 0.0)])
    assert fleet.robot("r1").ranges[AHEAD] == pytest.approx(1.95 + 1.0 + SENSOR_BACK)


def test_reset_robot_restarts_one_robot_while_the_world_goes_on() -> None:
    fleet = Fleet(face_to_face(), make_config())
    for _ in range(150):
        fleet.step([(-0.2, 0.0), (0.0, 0.5)])  # r1 backs into the west wall, r2 turns on the spot
    r2_pose = fleet.robot("r2").pose
    assert fleet.robot("r1").collisions == 1 and fleet.robot("r1").pose.x == pytest.approx(-1.95 + RADIUS, abs=0.002)
    fleet.reset_robot("r1")
    r1 = fleet.robot("r1")
    assert r1.pose == (-1.0, 0.0, 0.0) and r1.collisions == 0 and len(r1.trajectory) == 1
    assert fleet.steps == 150 and fleet.robot("r2").pose == r2_pose
    for _ in range(100):
        fleet.step([(-0.2, 0.0), (0.0, 0.0)])  # into the wall again
    fleet.set_pose(-1.0, 0.1, 0.0, robot="r2")  # onto r1's start
    with pytest.raises(SimulationError, match="robot 'r1' .* overlaps robot 'r2'"):
        fleet.reset_robot("r1")
    assert fleet.robot("r1").collisions == 1 and fleet.robot("r1").pose.x < -1.8  # untouched by the refusal


def test_reset_puts_everyone_back_and_replays_the_same_run() -> None:
    config = make_config(lidar={"noise_std": 0.01}, encoders={"noise": 0.01, "slip": 0.02})
    fleet = Fleet(face_to_face(), config)
    runs = []
    for _ in range(2):
        for k in range(80):
            fleet.step([(0.2, math.sin(k / 9.0)), (0.15, -0.4)])
        runs.append([(r.pose, r.odom_pose, np.asarray(r.ranges).copy(), r.collisions) for r in fleet.robots])
        fleet.reset()
        assert fleet.steps == 0 and fleet.robots[1].pose == (1.0, 0.0, -math.pi)
    for (pose, odom, ranges, hits), (pose2, odom2, ranges2, hits2) in zip(*runs, strict=True):
        assert (pose, odom, hits) == (pose2, odom2, hits2)
        np.testing.assert_array_equal(ranges, ranges2)


def test_the_one_robot_simulator_refuses_a_fleet_and_a_fleet_refuses_a_start_override() -> None:
    with pytest.raises(SimulationError, match="lists 2 robots \\(r1, r2\\).*Fleet"):
        Simulator(face_to_face(), make_config())
    with pytest.raises(ConfigError, match="start: .*room.yaml lists its robots"):
        Fleet(face_to_face(), make_config(start=(0.0, 0.0, 0.0)))
    one = Simulator(room(("solo", (0.0, 0.0, 0.0))), make_config())  # a list of one is fine
    assert one.fleet.names == ("solo",)


def test_a_world_without_a_robot_list_is_one_unnamed_robot() -> None:
    world = load_world(WORLDS / "open_room.yaml")
    fleet = Fleet(world, make_config())
    assert fleet.names == ("",) and fleet.robots[0].pose == world.start and fleet.robots[0].goal == world.goal


def test_starts_that_overlap_are_refused_when_the_fleet_is_built() -> None:
    with pytest.raises(ValueError, match="room.yaml: robots\\[1\\].start: .*r2 overlaps r1"):
        Fleet(room(("r1", (0.0, 0.0, 0.0)), ("r2", (0.15, 0.0, 0.0))), make_config())
    with pytest.raises(ValueError, match="room.yaml: robots\\[0\\].start: .*overlaps a solid"):
        Fleet(room(("r1", (1.9, 0.0, 0.0))), make_config())
    # a smaller robot fits
    Fleet(room(("r1", (0.0, 0.0, 0.0)), ("r2", (0.15, 0.0, 0.0))), make_config(robot=RobotConfig(radius=0.07)))


def test_the_shipped_fleet_world_loads_runs_and_renders(tmp_path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PathCollection
    from matplotlib.figure import Figure

    from amr_simulation.render import draw_fleet

    fleet = Fleet(load_world(WORLDS / "fleets" / "crossing.yaml"), make_config(lidar={"noise_std": 0.01}))
    assert fleet.names == ("r1", "r2", "r3", "r4") and all(robot.goal is not None for robot in fleet.robots)
    for _ in range(10):
        fleet.step([(0.2, 0.0)] * 4)
    assert fleet.render(tmp_path / "crossing.png", dpi=40).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    figure = Figure()
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    draw_fleet(ax, fleet)
    scans = [c for c in ax.collections if isinstance(c, PathCollection)]  # one scatter of returns per robot
    assert [len(c.get_offsets()) for c in scans] == [int(np.isfinite(r.ranges).sum()) for r in fleet.robots]
