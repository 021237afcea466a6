"""Pure pursuit (library): curvature, turning in place, the goal, scan safety, bad input; and a closed loop
in the simulator library on hard_maze (its grid form gives the occupancy grid exactly, no rasterizer)."""

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from support.control import cast, corridor

from amr_control.path_follower import PathError, PathFollower, State
from amr_control.path_follower_config import ConfigError, PathFollowerConfig
from amr_maps.occupancy_grid import OccupancyGrid
from amr_maps.world import load_world
from amr_planning.astar import GridAStar
from amr_planning.costmap import Costmap
from amr_planning.smoothing import smooth_path
from amr_simulation.config import LidarConfig, SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.scan import ScanData

ROOT = Path(__file__).resolve().parents[2]
CENTRED_LIDAR = PathFollowerConfig(lidar_x=0.0)  # the synthetic scans are cast from the rotation centre


def straight(length: float = 2.0, step: float = 0.05) -> np.ndarray:
    xs = np.arange(0.0, length + 1e-9, step)
    return np.stack([xs, np.zeros_like(xs)], axis=1)


def drive(follower: PathFollower, pose, steps: int, dt: float = 0.05):
    """Ideal unicycle integration of the follower's commands; the poses and commands."""
    x, y, theta = pose
    history = []
    for _ in range(steps):
        command = follower.compute(x, y, theta)
        history.append(((x, y, theta), command))
        if command.reached:
            break
        x += command.v * dt * math.cos(theta + 0.5 * command.w * dt)
        y += command.v * dt * math.sin(theta + 0.5 * command.w * dt)
        theta += command.w * dt
    return history


def test_on_the_path_heading_along_it_drives_straight_at_cruise_speed():
    follower = PathFollower()
    follower.set_path(straight())
    command = follower.compute(0.3, 0.0, 0.0)
    assert command.state is State.TRACK
    assert command.v == pytest.approx(follower.config.linear_speed) and command.w == pytest.approx(0.0)
    assert command.cross_track == pytest.approx(0.0) and command.remaining == pytest.approx(1.7)


def test_the_curvature_is_two_sin_alpha_over_the_lookahead_distance():
    follower = PathFollower(PathFollowerConfig(curve_angular_speed=100.0, lookahead_distance=0.2))
    follower.set_path(straight())
    command = follower.compute(0.5, -0.1, 0.0)  # lookahead point (0.7, 0): 0.2 ahead, 0.1 to the left
    dx, dy = 0.2, 0.1
    alpha = math.atan2(dy, dx)
    assert command.w / command.v == pytest.approx(2.0 * math.sin(alpha) / math.hypot(dx, dy))
    assert command.cross_track == pytest.approx(0.1)


def test_speed_drops_in_curves_and_near_the_goal():
    follower = PathFollower()
    follower.set_path(straight())
    curved = follower.compute(1.0, -0.15, -0.5)  # lookahead point 65 deg to the left
    assert abs(curved.w) <= follower.config.curve_angular_speed + 1e-9
    assert curved.v < follower.config.linear_speed
    follower.set_path(straight())
    near = follower.compute(1.9, 0.0, 0.0)
    assert near.v == pytest.approx(max(follower.config.approach_gain * 0.1, follower.config.min_linear_speed))


def test_a_path_starting_behind_is_met_by_turning_in_place_first():
    follower = PathFollower()
    follower.set_path(straight())
    history = drive(follower, (0.2, 0.0, math.pi), 400)
    first = history[0][1]
    assert first.state is State.ALIGN and first.v == 0.0 and abs(first.w) > 0.0
    aligned = next(i for i, (_, c) in enumerate(history) if c.state is State.TRACK)
    assert all(c.v == 0.0 for _, c in history[:aligned])
    assert history[-1][1].reached
    assert all(math.isfinite(c.v) and math.isfinite(c.w) for _, c in history)


def test_tracking_a_curved_path_converges_and_stops_at_the_goal_heading():
    t = np.linspace(0.0, math.pi, 80)
    path = np.stack([np.sin(t), 1.0 - np.cos(t)], axis=1)  # a half circle of radius 1 m
    follower = PathFollower()
    follower.set_path(path, goal_heading=math.pi / 2)
    history = drive(follower, (0.0, -0.1, 0.0), 1000)
    final_pose, final = history[-1]
    assert final.reached and final.v == 0.0 and final.w == 0.0
    assert math.hypot(final_pose[0] - path[-1, 0], final_pose[1] - path[-1, 1]) <= follower.config.goal_tolerance
    assert abs(math.remainder(final_pose[2] - math.pi / 2, 2 * math.pi)) <= math.radians(10.0) + 1e-9
    assert any(c.state is State.HEADING for _, c in history)
    late = [c.cross_track for _, c in history[len(history) // 3 :] if c.state is State.TRACK]
    assert max(late) < 0.03
    assert follower.compute(*final_pose).reached  # stays reached


def test_a_wall_ahead_within_the_margin_stops_the_robot_and_a_lasting_block_asks_for_a_replan():
    follower = PathFollower(CENTRED_LIDAR)
    follower.set_path(straight())
    scan = cast(corridor(left=0.4, right=0.4, front=0.105 + 0.015))  # 1.5 cm in front of the disc
    first = follower.compute(0.0, 0.0, 0.0, scan)
    assert first.state is State.BLOCKED and first.v == 0.0 and first.w == 0.0 and not first.replan
    assert "within" in first.message
    commands = [follower.compute(0.0, 0.0, 0.0, scan) for _ in range(12)]
    assert all(c.v == 0.0 for c in commands) and commands[-1].replan and "replan" in commands[-1].message
    free = follower.compute(0.0, 0.0, 0.0, cast(corridor(left=0.4, right=0.4, front=1.0)))
    assert free.state is State.TRACK and free.v > 0.0


def test_a_blocked_robot_turns_in_place_towards_the_path_never_forwards():
    follower = PathFollower(CENTRED_LIDAR)
    follower.set_path(straight())
    heading = 0.4  # turned left of the path, a wall 1.5 cm ahead of its disc along that heading
    wall = 0.105 + 0.015
    scan = cast(
        [
            (
                wall * math.cos(heading) - math.sin(heading),
                wall * math.sin(heading) + math.cos(heading),
                wall * math.cos(heading) + math.sin(heading),
                wall * math.sin(heading) - math.cos(heading),
            )
        ],
        heading=heading,
    )
    command = follower.compute(0.0, 0.0, heading, scan)
    assert command.state is State.BLOCKED and command.v == 0.0 and command.w < 0.0


def test_grazing_a_wall_with_the_path_straight_ahead_turns_away_and_drives_clear_never_closer():
    """A wall along the path 7 mm from the disc on the right (the path drawn from a pose estimate 2 cm
    off): every forward arc approaches it and a new plan from here is the same path. Before the escape
    the follower stood still for ever (bench_navigation: a 0.35 m bend); now it turns left, away from
    the wall, drives away from it, and hands back to pursuit."""
    follower = PathFollower(CENTRED_LIDAR)
    follower.set_path(straight())
    wall = [(-0.3, -0.112, 1.0, -0.112)]
    x, y, theta, dt = 0.0, 0.0, 0.0, 0.05
    clearance = [0.112]
    states = []
    for _ in range(200):
        moved = [(x0 - x, y0 - y, x1 - x, y1 - y) for x0, y0, x1, y1 in wall]
        scan = cast(moved, heading=theta)  # range_min 0.05: the TurtleBot's LiDAR sits 3.2 cm behind the centre
        command = follower.compute(
            x, y, theta, ScanData(scan.ranges, scan.angle_min, scan.angle_increment, 0.05, scan.range_max)
        )
        states.append((command.state, command.v, command.w))
        if command.state is State.TRACK and any(s is State.ESCAPE and v > 0 for s, v, _ in states):
            break
        x += command.v * dt * math.cos(theta + 0.5 * command.w * dt)
        y += command.v * dt * math.sin(theta + 0.5 * command.w * dt)
        theta += command.w * dt
        clearance.append(y + 0.112)
    assert states[0][0] is State.ESCAPE and states[0][1] == 0.0 and states[0][2] > 0.0  # turns left, away
    assert any(s is State.ESCAPE and v > 0.0 and w == 0.0 for s, v, w in states)  # then straight on
    assert min(clearance) >= clearance[0] - 1e-9 and clearance[-1] > clearance[0] + 0.01
    assert states[-1][0] is State.TRACK


def test_one_or_two_noisy_beams_do_not_stop_it_but_side_walls_within_the_margin_do_not_either():
    follower = PathFollower(CENTRED_LIDAR)
    follower.set_path(straight())
    ranges = np.array(cast(corridor(left=0.13, right=0.13)).ranges)  # 0.35 m wide corridor, off-centre
    ranges[2] = 0.11  # two beams reading a phantom just ahead
    ranges[3] = 0.11
    command = follower.compute(0.0, 0.0, 0.0, ScanData(ranges, 0.0, 2 * math.pi / 240, 0.12, 3.5))
    assert command.state is State.TRACK and command.v > 0.0


def test_bad_scans_and_poses_stop_the_robot_with_a_message_never_nan():
    follower = PathFollower()
    follower.set_path(straight())
    nan_scan = ScanData(np.full(240, np.nan), 0.0, 2 * math.pi / 240, 0.12, 3.5)
    assert follower.compute(0.3, 0.0, 0.0, nan_scan).v > 0.0  # no return is no obstacle (REP 117)
    for scan in (ScanData([], 0.0, 0.1), ScanData(np.ones(10), math.nan, 0.1), ScanData("abc", 0.0, 0.1)):
        command = follower.compute(0.3, 0.0, 0.0, scan)
        assert (command.v, command.w) == (0.0, 0.0) and "scan" in command.message
    for pose in ((math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (0.0, 0.0, None)):
        command = follower.compute(*pose)
        assert (command.v, command.w) == (0.0, 0.0) and "pose" in command.message


def test_a_pose_that_jumps_off_the_path_stops_and_asks_for_a_replan():
    follower = PathFollower()
    follower.set_path(straight())
    assert follower.compute(0.5, 0.0, 0.0).state is State.TRACK
    jumped = follower.compute(0.6, 0.6, 0.0)
    assert jumped.state is State.STRAYED and jumped.replan and (jumped.v, jumped.w) == (0.0, 0.0)
    assert follower.compute(0.6, 0.0, 0.0).state is State.TRACK  # back on the path: on it goes


def test_progress_is_not_short_cut_where_a_path_passes_close_to_itself():
    # a hairpin: out along y = 0, back along y = 0.3; the robot on the way out must not jump to the way back
    out = straight(2.0)
    back = out[::-1] + (0.0, 0.3)
    follower = PathFollower()
    follower.set_path(np.vstack([out, back]))
    for x in np.arange(0.2, 1.6, 0.05):
        command = follower.compute(float(x), 0.12, 0.0)
        assert command.remaining > 2.0


@pytest.mark.parametrize(
    "path, words",
    [
        ([], "non-empty"),
        ([[0.0, 0.0, 0.0]], "non-empty"),
        ([[0.0, math.nan], [1.0, 0.0]], "finite"),
        ("ab", "numbers|non-empty"),
    ],
)
def test_bad_paths_are_refused(path, words):
    follower = PathFollower()
    with pytest.raises(PathError, match=words):
        follower.set_path(path)
    assert follower.compute(0.0, 0.0, 0.0).state is State.IDLE


def test_a_one_point_path_is_a_goal_to_drive_to():
    follower = PathFollower()
    follower.set_path([[0.5, 0.0]])
    assert drive(follower, (0.0, 0.0, 0.0), 200)[-1][1].reached


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"lookahead_distance": 0.0}, "lookahead_distance"),
        ({"safety_margin": -0.1}, "safety_margin"),
        ({"min_linear_speed": 0.5}, "min_linear_speed"),
        ({"aligned_angle_deg": 90.0}, "aligned_angle_deg"),
        ({"goal_tolerance": math.nan}, "goal_tolerance"),
    ],
)
def test_bad_configs_are_refused_by_name(kwargs, name):
    with pytest.raises(ConfigError, match=name):
        PathFollowerConfig(**kwargs)
    with pytest.raises(ConfigError, match="unknown"):
        PathFollowerConfig.from_params({"lookahead": 0.3})


def grid_world_map(world_file: Path, resolution: float) -> OccupancyGrid:
    """The occupancy grid of a world written in the grid form, exact at a divisor of its cell size."""
    grid = yaml.safe_load(world_file.read_text())["grid"]
    factor = round(grid["cell_size"] / resolution)
    solid = np.array([[c == "#" for c in row] for row in reversed(grid["rows"])])
    data = np.kron(solid, np.ones((factor, factor), dtype=bool)).astype(np.int8) * 100
    return OccupancyGrid(data, resolution, (grid["origin"][0], grid["origin"][1], 0.0))


def test_plan_and_follow_through_hard_maze_with_noisy_lidar_without_touching_a_wall():
    world_file = ROOT / "config" / "worlds" / "hard_maze.yaml"
    world = load_world(world_file)
    costmap = Costmap(grid_world_map(world_file, 0.05))
    path = smooth_path(GridAStar(costmap).plan(world.start[:2], (world.goal.x, world.goal.y)).points, costmap)
    sim = Simulator(world, SimulationConfig(seed=3, lidar=LidarConfig(noise_std=0.03)))
    follower = PathFollower()
    follower.set_path(path)
    lidar = sim.lidar
    errors = []
    while sim.time < 150.0 and not sim.goal_reached:
        pose = sim.pose
        scan = ScanData(sim.ranges, lidar.angle_min, lidar.angle_increment, lidar.range_min, lidar.range_max)
        command = follower.compute(pose.x, pose.y, pose.theta, scan)
        assert math.isfinite(command.v) and math.isfinite(command.w)
        if command.state is State.TRACK:
            errors.append(command.cross_track)
        sim.step(command.v, command.w)
    assert sim.goal_reached, f"goal not reached in {sim.time:.1f} s"
    assert sim.collisions == 0
    assert np.mean(errors) < 0.03
    assert sim.time < 120.0  # the wall follower alone needs about 365 s here


@pytest.mark.parametrize("name", ["path_follower_sim.yaml", "path_follower_real.yaml"])
def test_the_shipped_parameter_files_are_valid(name):
    from amr_control.path_follower_config import read_parameter_file

    config = read_parameter_file(ROOT / "config" / name)
    assert config.simulation == (name == "path_follower_sim.yaml")
    assert config.flip_angular_sign == (name == "path_follower_real.yaml")
