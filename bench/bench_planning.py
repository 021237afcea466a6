"""Planning and path following figures (library level, no ROS): prints, asserts nothing.

1. A* time on the shipped worlds rasterized at 0.05 m (target <= 20 ms), and its growth on synthetic
   maps of 10, 20 and 40 m square at 0.05 m (target <= 200 ms at 20 m, 160,000 cells): random blocks
   (corner to corner) and generated loop mazes (start cell to the far corner).
2. The roadmap planner's build and query times on the same maps.
3. Path following from the true pose on the shipped worlds: mean cross-track error (target <= 3 cm).
4. Plan + follow from the true pose on generated mazes (every family, widths down to 0.35 m, LiDAR
   noise 0 / 0.01 / 0.03 m): the family's goal (one a wall follower reaches) and a random free goal
   (often one it cannot: islands, mid-room); reached (target >= 98 %), collision-free (target 100 %),
   and the time to the family's goal against the wall follower alone (target: faster in >= 90 %).

    python bench/bench_planning.py [--seeds 4] [--repeat 20] [--quick]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from generated_cases import far_free_point, maze_variant  # noqa: E402

from amr_control.path_follower import PathFollower, State  # noqa: E402
from amr_control.wall_follower import WallFollower  # noqa: E402
from amr_control.wall_follower_config import read_parameter_file  # noqa: E402
from amr_maps.maze_families import FAMILIES, generate  # noqa: E402
from amr_maps.occupancy_grid import OccupancyGrid  # noqa: E402
from amr_maps.rasterize import rasterize_world  # noqa: E402
from amr_maps.world import Goal, World, load_world, world_from_dict  # noqa: E402
from amr_planning.astar import GridAStar  # noqa: E402
from amr_planning.costmap import Costmap  # noqa: E402
from amr_planning.errors import PlanningError  # noqa: E402
from amr_planning.roadmap import Roadmap, RoadmapConfig  # noqa: E402
from amr_planning.smoothing import smooth_path  # noqa: E402
from amr_simulation.config import LidarConfig, SimulationConfig  # noqa: E402
from amr_simulation.simulator import Simulator  # noqa: E402
from amr_util.scan import ScanData  # noqa: E402

RESOLUTION = 0.05
LOOP_RESOLUTION = 0.025  # closed loops: at 0.05 m the conservative map closes many 0.35 m corridors
MAX_REPLANS = 20
PRM_MAX_NODES = 24000  # 60 nodes per m2, capped (the build is about 0.3 ms per node)
WORLDS = sorted((ROOT / "config" / "worlds").glob("*.yaml"))
WALL_CONFIG = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
FOLLOW_LIMIT = 600.0  # s simulated for plan + follow (as for the wall follower)
WALL_LIMIT = 600.0  # s simulated for the wall follower alone


def median_ms(function, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        began = time.perf_counter()
        function()
        times.append(time.perf_counter() - began)
    return 1e3 * statistics.median(times)


# -- 1 and 2: planning times ----------------------------------------------------------------


def block_map(size: float, seed: int) -> OccupancyGrid:
    """A size x size m walled area with random blocks (a fifth of the area), corners kept free."""
    n = round(size / RESOLUTION)
    rng = np.random.default_rng(seed)
    data = np.zeros((n, n), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    for _ in range(int(size * size / 1.5)):
        r, c = rng.integers(0, n, 2)
        h, w = rng.integers(4, 24, 2)
        data[r:r + h, c:c + w] = 100
    data[1:20, 1:20] = data[-20:-1, -20:-1] = 0
    return OccupancyGrid(data, RESOLUTION)


def planning_times(repeat: int) -> None:
    print("== A* and PRM planning time (median of runs; costmap build apart)")
    print(f"{'map':28s} {'cells':>8s} {'costmap':>9s} {'A*':>9s} {'expanded':>9s} {'PRM build':>10s} "
          f"{'PRM query':>10s} {'nodes':>6s}")
    cases = []
    for path in WORLDS:
        world = load_world(path)
        goal = (world.goal.x, world.goal.y) if world.goal else None
        cases.append((path.stem, rasterize_world(world, RESOLUTION), (world.start.x, world.start.y), goal))
    for size in (10, 20, 40):
        grid = block_map(size, seed=size)
        cases.append((f"blocks {size} x {size} m", grid, (0.5, 0.5), (size - 0.5, size - 0.5)))
    for size in (10, 20):
        world = world_from_dict(generate("loops", 1, size=float(size), width=0.5))
        cases.append((f"loop maze {size} x {size} m", rasterize_world(world, RESOLUTION),
                      (world.start.x, world.start.y), None))
    for name, grid, start, goal in cases:
        build = median_ms(lambda: Costmap(grid), max(3, repeat // 4))
        costmap = Costmap(grid)
        goal = goal if goal is not None else far_free_point(costmap, start)
        planner = GridAStar(costmap)
        try:
            astar = median_ms(lambda: planner.plan(start, goal), repeat)
            expanded = planner.plan(start, goal).expanded
        except PlanningError as error:
            print(f"{name:28s} A* failed: {error}")
            continue
        area = (grid.width * grid.height) * RESOLUTION**2
        config = RoadmapConfig(node_count=int(min(max(200, 60 * area), PRM_MAX_NODES)), connection_distance=0.6, seed=0)
        prm_build = median_ms(lambda: Roadmap(costmap, config), 1 if config.node_count > 10000 else 3)
        roadmap = Roadmap(costmap, config)
        try:
            prm_query = f"{median_ms(lambda: roadmap.plan(start, goal), repeat):9.1f}"
        except PlanningError:
            prm_query = "  no path"
        print(f"{name:28s} {grid.width * grid.height:8d} {build:7.1f}ms {astar:7.1f}ms {expanded:9d} "
              f"{prm_build:8.1f}ms {prm_query}ms {config.node_count:6d}")


# -- 3 and 4: closed loops --------------------------------------------------------------------


@dataclasses.dataclass
class Run:
    planned: bool
    reached: bool
    collisions: int
    time: float
    cross_track: float
    message: str = ""
    replans: int = 0


def plan_and_follow(world: World, goal, noise: float, seed: int, resolution: float = LOOP_RESOLUTION,
                    limit: float = FOLLOW_LIMIT) -> Run:
    """Plan on the rasterized world from the true start, then follow with pure pursuit on the true pose;
    when the follower asks for a new plan (blocked), plan again from where the robot is, as the planner
    node does (at most MAX_REPLANS times)."""
    costmap = Costmap(rasterize_world(world, resolution))
    planner = GridAStar(costmap)
    sim = Simulator(world, SimulationConfig(seed=seed, lidar=LidarConfig(noise_std=noise)))
    follower = PathFollower()
    lidar = sim.lidar
    errors = []
    replans = 0
    try:
        follower.set_path(smooth_path(planner.plan((world.start.x, world.start.y), goal).points, costmap))
    except PlanningError as error:
        return Run(False, False, 0, math.nan, math.nan, str(error))
    while sim.time < limit and not sim.goal_reached:
        pose = sim.pose
        scan = ScanData(sim.ranges, lidar.angle_min, lidar.angle_increment, lidar.range_min, lidar.range_max)
        command = follower.compute(pose.x, pose.y, pose.theta, scan)
        if command.state is State.TRACK:
            errors.append(command.cross_track)
        if command.reached:
            break
        if command.replan:
            if replans == MAX_REPLANS:
                break
            replans += 1
            try:
                follower.set_path(smooth_path(planner.plan((pose.x, pose.y), goal).points, costmap))
            except PlanningError as error:
                return Run(True, False, sim.collisions, sim.time, math.nan, f"replan failed: {error}")
        sim.step(command.v, command.w)
    message = "" if sim.goal_reached else f"stopped in {follower.state.value} at t={sim.time:.1f} s"
    if replans:
        message += f" ({replans} replans)"
    mean_error = float(np.mean(errors)) if errors else math.nan
    return Run(True, sim.goal_reached, sim.collisions, sim.time, mean_error, message.strip(), replans)


def wall_follow(world: World, hand: str, noise: float, seed: int) -> Run:
    sim = Simulator(world, SimulationConfig(seed=seed, lidar=LidarConfig(noise_std=noise)))
    follower = WallFollower(dataclasses.replace(WALL_CONFIG, preferred_wall=hand))
    lidar = sim.lidar
    while sim.time < WALL_LIMIT and not sim.goal_reached:
        scan = ScanData(sim.ranges, lidar.angle_min, lidar.angle_increment, lidar.range_min, lidar.range_max)
        command = follower.compute(scan, *sim.odom_twist, sim.time)
        sim.step(command.v, command.w)
    return Run(True, sim.goal_reached, sim.collisions, sim.time, math.nan)


def with_goal(world_dict: dict, goal, radius: float) -> World:
    return world_from_dict({**world_dict, "goal": [float(goal[0]), float(goal[1]), radius]})


def shipped_worlds() -> None:
    print("\n== Path following from the true pose on the shipped worlds (LiDAR noise 0.01 m)")
    for path in WORLDS:
        world = load_world(path)
        if world.goal is None:  # a far free point as the goal
            costmap = Costmap(rasterize_world(world, RESOLUTION))
            goal = far_free_point(costmap, (world.start.x, world.start.y))
            world = dataclasses.replace(world, goal=Goal(float(goal[0]), float(goal[1]), 0.1))
        goal_xy = (world.goal.x, world.goal.y)
        for resolution in (RESOLUTION, LOOP_RESOLUTION):
            run = plan_and_follow(world, goal_xy, 0.01, seed=0, resolution=resolution)
            print(f"{path.stem:16s} map {resolution} m: reached={run.reached} t={run.time:6.1f} s "
                  f"collisions={run.collisions} mean cross-track={100 * run.cross_track:.2f} cm {run.message}")


def generated_mazes(seeds: int) -> None:
    print("\n== Plan + follow from the true pose on generated mazes, against the wall follower alone")
    runs, comparisons, failures = [], [], []
    cross_tracks = []
    began = time.perf_counter()
    for family in FAMILIES:
        for seed in range(seeds):
            options, _, noise, hand = maze_variant(family, seed)
            world_dict = generate(family, seed, **options)
            world = world_from_dict(world_dict)
            family_goal = (world.goal.x, world.goal.y)
            costmap = Costmap(rasterize_world(world, LOOP_RESOLUTION))
            try:
                random_goal = far_free_point(costmap, (world.start.x, world.start.y), np.random.default_rng(seed))
            except PlanningError as error:
                failures.append(f"{family} seed {seed}: no free start ({error})")
                continue
            for kind, goal, radius in (("family", family_goal, world.goal.radius), ("random", random_goal, 0.1)):
                run = plan_and_follow(with_goal(world_dict, goal, radius), goal, noise, seed)
                runs.append((family, kind, run))
                if not math.isnan(run.cross_track):
                    cross_tracks.append(run.cross_track)
                if not run.reached or run.collisions:
                    failures.append(f"{family} seed {seed} width {options.get('width', '-')} noise {noise} {kind} goal: "
                                    f"reached={run.reached} collisions={run.collisions} {run.message}")
                if kind == "family":
                    wall = wall_follow(world, hand, noise, seed)
                    if run.reached and wall.reached:
                        comparisons.append((family, run.time, wall.time))
    total = len(runs)
    reached = sum(r.reached for _, _, r in runs)
    clean = sum(r.collisions == 0 for _, _, r in runs)
    faster = sum(p < w for _, p, w in comparisons)
    print(f"{total} runs over {len(FAMILIES)} families x {seeds} seeds x 2 goals "
          f"({time.perf_counter() - began:.0f} s wall clock)")
    for family in FAMILIES:
        mine = [r for f, _, r in runs if f == family]
        times = [(p, w) for f, p, w in comparisons if f == family]
        ratio = statistics.median([w / p for p, w in times]) if times else math.nan
        print(f"  {family:11s} reached {sum(r.reached for r in mine)}/{len(mine)}, collision-free "
              f"{sum(r.collisions == 0 for r in mine)}/{len(mine)}, both solve {len(times)}, "
              f"median wall-follower time / plan+follow time {ratio:.2f}")
    print(f"reached: {reached}/{total} = {100 * reached / total:.1f} % (target >= 98 %)")
    print(f"collision-free: {clean}/{total} = {100 * clean / total:.1f} % (target 100 %)")
    if comparisons:
        print(f"faster than the wall follower: {faster}/{len(comparisons)} = {100 * faster / len(comparisons):.1f} % "
              f"of the worlds both solve (target >= 90 %)")
    if cross_tracks:
        print(f"mean cross-track error over the runs: {100 * statistics.mean(cross_tracks):.2f} cm")
    replanned = [r.replans for _, _, r in runs if r.replans]
    print(f"runs that replanned after a block: {len(replanned)} ({sum(replanned)} replans)")
    for line in failures:
        print("  not reached / collided:", line)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=6, help="generated mazes per family")
    parser.add_argument("--repeat", type=int, default=20, help="timed runs per planning case")
    parser.add_argument("--quick", action="store_true", help="2 seeds, 5 repeats")
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.repeat = 2, 5
    planning_times(args.repeat)
    shipped_worlds()
    generated_mazes(args.seeds)


if __name__ == "__main__":
    main()
