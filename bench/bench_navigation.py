"""The whole navigation loop at library level (no ROS): explore by wall following until the particle
filter says localized, plan from the ESTIMATED pose (A* on the costmap, smoothing), follow with pure
pursuit on the estimated pose, replan when strayed / blocked / the goal changes, explore again if the
filter withdraws `localized` (amr_planning.navigation, which mirrors the maze_navigation nodes).

Prints per run: when the filter first said localized, the goal reached time or why not, collisions,
mean cross-track error (true pose to the followed path while tracking), and the wall follower alone's
time on the same case (same world, seed, noise, hand). Then: % reached, % collision-free, faster than
the wall follower in X of Y cases both solve. Asserts nothing.

Cases: the shipped worlds with a goal (a few seeds); inner_maze and outer_corridor, which have none,
with their far free point (as bench_planning.py); twin_rooms (symmetric: the filter must never say
localized there, so no goal is expected; reported apart, as are generated worlds whose walls map onto
themselves under a 90 or 180 deg rotation, e.g. plain rectangular open rooms); generated mazes of amr_maps.maze_families
(corridors 0.35 / 0.45 / 0.6 m, LiDAR noise 0 / 0.01 / 0.03 m cycled over the seeds, as bench_planning.py)
with the family's goal (reachable by the wall follower's hand) and a random free goal in the start's
connected free space (often one no wall follower reaches).

Configuration: config/particle_filter.yaml (map rasterized at its 0.02 m), config/planner.yaml (0.025 m),
config/path_follower_sim.yaml, config/wall_follower_sim.yaml (preferred_wall = the family's hand);
encoder noise 0.02 and slip 0.05 (as bench_wall_follower_families.py) unless --encoder-noise/--slip.

    python bench/bench_navigation.py [--quick] [--seeds 6] [--families perfect,loops] [--jobs 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import multiprocessing
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from generated_cases import far_free_point, maze_variant  # noqa: E402

from amr_control.path_follower import PathFollower  # noqa: E402
from amr_control.path_follower_config import read_parameter_file as read_follower_file  # noqa: E402
from amr_control.wall_follower import WallFollower  # noqa: E402
from amr_control.wall_follower_config import read_parameter_file as read_wall_file  # noqa: E402
from amr_localization.particle_filter import ParticleFilter  # noqa: E402
from amr_localization.particle_filter_parameters import config_of  # noqa: E402
from amr_maps.maze_families import FAMILIES, generate  # noqa: E402
from amr_maps.rasterize import rasterize_world  # noqa: E402
from amr_maps.world import Goal, World, load_world, world_from_dict  # noqa: E402
from amr_planning.navigation import Navigator, run_navigation  # noqa: E402
from amr_planning.planner import Planner, PlannerConfig  # noqa: E402
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig  # noqa: E402
from amr_simulation.simulator import Simulator  # noqa: E402
from amr_util.parameter_file import node_parameters  # noqa: E402
from amr_util.scan import scan_of  # noqa: E402

CONFIG = ROOT / "config"
WORLDS = CONFIG / "worlds"
WALL_CONFIG = read_wall_file(CONFIG / "wall_follower_sim.yaml")
FOLLOWER_CONFIG = read_follower_file(CONFIG / "path_follower_sim.yaml")
PLANNER_PARAMS = node_parameters(CONFIG / "planner.yaml", "planner")
FILTER_PARAMS = node_parameters(CONFIG / "particle_filter.yaml", "particle_filter")
LIMIT = 600.0
MAX_COLLISIONS = 5


@dataclasses.dataclass(frozen=True)
class Case:
    label: str
    kind: str  # shipped, symmetric, family goal, random goal
    world: dict | str  # a generated world dict, or a shipped world's file name
    seed: int
    noise: float
    hand: str
    goal: tuple[float, float] | None = None  # overrides the world's goal (radius goal_radius)
    goal_radius: float = 0.1
    compare: bool = True  # run the wall follower alone too
    limit: float = LIMIT


def world_of(case: Case) -> World:
    if isinstance(case.world, str):
        world = load_world(WORLDS / case.world)
    else:
        world = world_from_dict(case.world)
    if case.goal is not None:
        world = dataclasses.replace(world, goal=Goal(float(case.goal[0]), float(case.goal[1]), case.goal_radius))
    return world


def sim_config(case: Case, encoder_noise: float, slip: float) -> SimulationConfig:
    return SimulationConfig(dt=WALL_CONFIG.dt, seed=case.seed, lidar=LidarConfig(noise_std=case.noise),
                            encoders=EncoderConfig(noise=encoder_noise, slip=slip))


def rotationally_symmetric(world: World, resolution: float = 0.02, tolerance: float = 0.05) -> str:
    """'' or the rotation ('90 deg', '180 deg') that maps the walls onto themselves: a robot cannot tell
    its pose from its rotated image there, so a particle filter must never say localized (twin_rooms)."""
    from scipy.ndimage import distance_transform_edt

    grid = rasterize_world(world, resolution)
    occupied = grid.occupied()
    rows, cols = np.nonzero(occupied)
    points = np.stack(grid.cell_to_world(rows, cols), axis=1)
    centre = points.mean(axis=0)
    distance = distance_transform_edt(~occupied) * resolution
    for degrees in (180, 90):
        c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
        turned = (points - centre) @ np.array([[c, s], [-s, c]]) + centre
        row, col = grid.world_to_cell(turned[:, 0], turned[:, 1])
        inside = (row >= 0) & (row < grid.height) & (col >= 0) & (col < grid.width)
        if inside.mean() > 0.99 and np.mean(distance[row[inside], col[inside]] <= tolerance) > 0.99:
            return f"{degrees} deg"
    return ""


def planner_for(world: World) -> Planner:
    config = PlannerConfig.from_params({**PLANNER_PARAMS, "world": ""})
    return Planner(rasterize_world(world, config.resolution), config)


def navigate(case: Case, encoder_noise: float, slip: float) -> dict:
    """One whole-loop run, and the wall follower alone on the same case."""
    began = time.perf_counter()
    world = world_of(case)
    planner = planner_for(world)
    goal = (world.goal.x, world.goal.y) if world.goal is not None else tuple(
        float(v) for v in far_free_point(planner.costmap, (world.start.x, world.start.y)))
    filter_config = config_of({**FILTER_PARAMS, "seed": case.seed})
    particle_filter = ParticleFilter(rasterize_world(world, FILTER_PARAMS["map_resolution"]), filter_config,
                                     range_max=FILTER_PARAMS["laser_max_range"])
    wall_config = dataclasses.replace(WALL_CONFIG, preferred_wall=case.hand)
    navigator = Navigator(planner, WallFollower(wall_config), PathFollower(FOLLOWER_CONFIG), goal)
    sim = Simulator(world, sim_config(case, encoder_noise, slip))
    run = run_navigation(sim, particle_filter, navigator, limit=case.limit, max_collisions=MAX_COLLISIONS)
    wall = None
    if case.compare and world.goal is not None:
        wall = wall_follow_alone(world, case, wall_config, encoder_noise, slip)
    radius = world.goal.radius if world.goal is not None else FOLLOWER_CONFIG.goal_tolerance + 0.05
    return {"case": case, "run": run, "wall": wall, "goal": goal, "radius": radius,
            "seconds": time.perf_counter() - began}


def wall_follow_alone(world: World, case: Case, wall_config, encoder_noise: float, slip: float):
    """(reached, time, collisions) of the wall follower alone until the simulator's goal region or the limit."""
    sim = Simulator(world, sim_config(case, encoder_noise, slip))
    follower = WallFollower(wall_config)
    while sim.time < LIMIT and not sim.goal_reached:
        command = follower.compute(scan_of(sim), *sim.odom_twist, sim.time)
        sim.step(command.v, command.w)
    return sim.goal_reached, sim.time, sim.collisions


# -- cases ------------------------------------------------------------------------------------


def shipped_cases(seeds: int, twin_limit: float) -> list[Case]:
    cases = []
    for path in sorted(WORLDS.glob("*.yaml")):
        world = load_world(path)
        for seed in range(seeds):
            if path.stem == "twin_rooms":
                cases.append(Case(f"twin_rooms s{seed}", "symmetric", path.name, seed, 0.01, WALL_CONFIG.preferred_wall,
                                  compare=False, limit=twin_limit))
            else:
                kind = "shipped" if world.goal is not None else "shipped, far free goal"
                cases.append(Case(f"{path.stem} s{seed}", kind, path.name, seed, 0.01, WALL_CONFIG.preferred_wall,
                                  compare=world.goal is not None))
    return cases


def maze_cases(families: list[str], seeds: int, random_goals: bool) -> list[Case]:
    cases = []
    for family in families:
        for seed in range(seeds):
            options, width, noise, hand = maze_variant(family, seed)
            world_dict = generate(family, seed, **options)
            width_label = f"w{width}" if "width" in options else "w-"
            label = f"{family} s{seed} {width_label} n{noise}"
            symmetry = rotationally_symmetric(world_from_dict(world_dict))
            if symmetry:  # no pose can be told from its rotated image: like twin_rooms, no goal is expected
                cases.append(Case(f"{label} (symmetric {symmetry})", "symmetric", world_dict, seed, noise, hand,
                                  compare=False))
                continue
            cases.append(Case(label + " family", "family goal", world_dict, seed, noise, hand))
            if random_goals:
                world = world_from_dict(world_dict)
                goal = tuple(float(v) for v in far_free_point(planner_for(world).costmap, (world.start.x, world.start.y),
                                                              np.random.default_rng(seed)))
                cases.append(Case(label + " random", "random goal", world_dict, seed, noise, hand, goal=goal,
                                  goal_radius=0.1, compare=False))
    return cases


# -- report -----------------------------------------------------------------------------------


def line(result: dict) -> str:
    case, run, wall = result["case"], result["run"], result["wall"]
    localized = f"{run.first_localized:6.1f}" if run.first_localized is not None else "     -"
    outcome = f"goal {run.time:6.1f}" if run.reached else f"FAIL: {run.reason} (t={run.time:.0f})"
    if case.kind == "symmetric" and not run.reached:
        outcome = f"no goal expected ({run.reason})"
    cross = f"{100 * run.mean_cross_track:5.2f}" if run.cross_track else "    -"
    if wall is None:
        alone = "-"
    else:
        alone = f"{wall[1]:6.1f}" if wall[0] else f"not in {LIMIT:.0f}"
    extra = []
    if run.localization_losses:
        extra.append(f"lost {run.localization_losses}x")
    if run.plans > 1:
        extra.append(f"{run.plans} plans")
    if run.planning_failures:
        extra.append(f"{len(run.planning_failures)} planning failures ({run.planning_failures[-1]})")
    if run.reached:
        extra.append(f"true dist to goal {100 * run.goal_distance:.1f} cm")
    return (f"{case.label:38s} loc {localized} s  {outcome:28s} coll {run.collisions}  xte {cross} cm  "
            f"est.err max {100 * run.max_localized_error:4.1f} cm  wall alone {alone:>10s}  "
            f"[{result['seconds']:.0f} s] {'; '.join(extra)}")


def summary(title: str, results: list[dict]) -> None:
    if not results:
        return
    total = len(results)
    # reached: the follower said REACHED and the true pose lies within the goal's radius
    reached = [r for r in results if r["run"].reached and r["run"].goal_distance <= r["radius"]]
    claimed = sum(r["run"].reached for r in results)
    clean = sum(r["run"].collisions == 0 for r in results)
    both = [r for r in results if r["wall"] is not None and r["wall"][0] and r in reached]
    faster = sum(r["run"].time < r["wall"][1] for r in both)
    crosses = [r["run"].mean_cross_track for r in results if r["run"].cross_track]
    localized = [r["run"].first_localized for r in results if r["run"].first_localized is not None]
    print(f"\n-- {title}: {total} runs")
    print(f"reached: {len(reached)}/{total} = {100 * len(reached) / total:.1f} % (target >= 98 %)"
          + (f"; the follower said reached in {claimed}" if claimed != len(reached) else ""))
    print(f"collision-free: {clean}/{total} = {100 * clean / total:.1f} % (target 100 %)")
    wall_only = sum(1 for r in results if r["wall"] is not None and r["wall"][0])
    if wall_only:
        ratios = [r["wall"][1] / r["run"].time for r in both]
        print(f"faster than the wall follower alone: {faster}/{len(both)} of the cases both solve "
              f"({100 * faster / max(len(both), 1):.0f} %, target >= 90 %; the wall follower alone solves {wall_only}); "
              f"median wall-follower time / loop time {statistics.median(ratios):.2f}" if ratios else "")
    if localized:
        print(f"first localized: median {statistics.median(localized):.1f} s, max {max(localized):.1f} s "
              f"({len(localized)}/{total} localized)")
    if crosses:
        print(f"mean cross-track error per run (true pose): median {100 * statistics.median(crosses):.2f} cm, "
              f"max {100 * max(crosses):.2f} cm (target <= 3 cm on the shipped worlds)")
    losses = [r["run"].localization_losses for r in results if r["run"].localization_losses]
    print(f"runs where the filter withdrew `localized` on the way: {len(losses)} ({sum(losses)} withdrawals)")
    for r in results:
        if r not in reached or r["run"].collisions:
            print("  not reached / collided:", line(r))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=9, help="generated mazes per family (default 9: every width x noise pair per family)")
    parser.add_argument("--shipped-seeds", type=int, default=3, help="seeds per shipped world (default 3)")
    parser.add_argument("--families", default=",".join(FAMILIES), help="comma-separated maze families (default all)")
    parser.add_argument("--no-random-goals", action="store_true", help="only the families' goals")
    parser.add_argument("--no-shipped", action="store_true")
    parser.add_argument("--twin-limit", type=float, default=120.0, help="s simulated in twin_rooms (default 120)")
    parser.add_argument("--encoder-noise", type=float, default=0.02)
    parser.add_argument("--slip", type=float, default=0.05)
    parser.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    parser.add_argument("--quick", action="store_true", help="2 seeds per family, 1 per shipped world, 60 s twin_rooms")
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.shipped_seeds, args.twin_limit = 2, 1, 60.0
    families = [f.strip() for f in args.families.split(",") if f.strip()]
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        parser.error(f"unknown families {unknown} (known: {', '.join(FAMILIES)})")
    cases = ([] if args.no_shipped else shipped_cases(args.shipped_seeds, args.twin_limit))
    cases += maze_cases(families, args.seeds, not args.no_random_goals)
    print(f"{len(cases)} runs, {args.jobs} processes, encoder noise {args.encoder_noise}, slip {args.slip}, "
          f"limit {LIMIT:.0f} s simulated, stop at {MAX_COLLISIONS} collisions; load {os.getloadavg()[0]:.1f}")
    print("columns: first localized (s), goal time or failure, collisions, mean cross-track error (true pose), "
          "largest estimate error while localized, wall follower alone's time [wall-clock s]")
    began = time.perf_counter()
    results = []
    task = _Task(args.encoder_noise, args.slip)
    with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
        for result in pool.imap(task, cases):
            results.append(result)
            print(line(result), flush=True)
    print(f"\n{time.perf_counter() - began:.0f} s wall clock, load {os.getloadavg()[0]:.1f} at the end")
    symmetric = [r for r in results if r["case"].kind == "symmetric"]
    for r in symmetric:
        run = r["run"]
        print(f"symmetric {r['case'].label}, {r['case'].limit:.0f} s: "
              + ("never localized (as expected)" if run.first_localized is None else
                 f"FALSE localization at {run.first_localized:.1f} s")
              + (f"; the wall follower passed the goal region while exploring at {run.time:.1f} s" if run.reached else ""))
    summary("shipped worlds with a goal", [r for r in results if r["case"].kind == "shipped"])
    summary("shipped worlds without one (far free goal)", [r for r in results if r["case"].kind == "shipped, far free goal"])
    mazes = [r for r in results if r["case"].kind in ("family goal", "random goal")]
    summary("generated mazes, family goals", [r for r in mazes if r["case"].kind == "family goal"])
    summary("generated mazes, random goals", [r for r in mazes if r["case"].kind == "random goal"])
    summary("generated mazes, all goals", mazes)
    summary("every run with a goal", [r for r in results if r["case"].kind != "symmetric"])


class _Task:
    def __init__(self, encoder_noise: float, slip: float) -> None:
        self.encoder_noise, self.slip = encoder_noise, slip

    def __call__(self, case: Case) -> dict:
        return navigate(case, self.encoder_noise, self.slip)


if __name__ == "__main__":
    main()
