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

3 and 4 are amr_evaluation episodes (controllers `plan_follow` and `wall_follower`) run by its runner:
`--jobs N` local processes, `--scheduler tcp://host:8786` a Dask cluster, `--results FILE` to keep and resume.

    python bench/bench_planning.py [--seeds 4] [--repeat 20] [--quick] [--jobs 2] [--no-timing]
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from amr_evaluation import configs
from amr_evaluation.cases import far_free_point, maze_variant
from amr_evaluation.episode import EpisodeSpec
from amr_evaluation.runner import run_sweep
from amr_maps.maze_families import FAMILIES, generate
from amr_maps.occupancy_grid import OccupancyGrid
from amr_maps.rasterize import rasterize_world
from amr_maps.world import load_world, world_from_dict
from amr_planning.astar import GridAStar
from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError
from amr_planning.roadmap import Roadmap, RoadmapConfig

ROOT = Path(__file__).resolve().parents[1]

RESOLUTION = 0.05
LOOP_RESOLUTION = 0.025  # closed loops: at 0.05 m the conservative map closes many 0.35 m corridors
PRM_MAX_NODES = 24000  # 60 nodes per m2, capped (the build is about 0.3 ms per node)
WORLDS = sorted((ROOT / "config" / "worlds").glob("*.yaml"))
PLAN_LABEL, PLAN_PARAMS = configs.resolve("plan_follow", "default")
WALL_LABEL, WALL_PARAMS = configs.resolve("wall_follower", "sim")
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
        data[r : r + h, c : c + w] = 100
    data[1:20, 1:20] = data[-20:-1, -20:-1] = 0
    return OccupancyGrid(data, RESOLUTION)


def planning_times(repeat: int) -> None:
    print("== A* and PRM planning time (median of runs; costmap build apart)")
    print(
        f"{'map':28s} {'cells':>8s} {'costmap':>9s} {'A*':>9s} {'expanded':>9s} {'PRM build':>10s} "
        f"{'PRM query':>10s} {'nodes':>6s}"
    )
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
        cases.append(
            (f"loop maze {size} x {size} m", rasterize_world(world, RESOLUTION), (world.start.x, world.start.y), None)
        )
    for name, grid, start, goal in cases:
        build = median_ms(functools.partial(Costmap, grid), max(3, repeat // 4))
        costmap = Costmap(grid)
        goal = goal if goal is not None else far_free_point(costmap, start)
        planner = GridAStar(costmap)
        try:
            astar = median_ms(functools.partial(planner.plan, start, goal), repeat)
            expanded = planner.plan(start, goal).expanded
        except PlanningError as error:
            print(f"{name:28s} A* failed: {error}")
            continue
        area = (grid.width * grid.height) * RESOLUTION**2
        config = RoadmapConfig(node_count=int(min(max(200, 60 * area), PRM_MAX_NODES)), connection_distance=0.6, seed=0)
        prm_build = median_ms(functools.partial(Roadmap, costmap, config), 1 if config.node_count > 10000 else 3)
        roadmap = Roadmap(costmap, config)
        try:
            prm_query = f"{median_ms(functools.partial(roadmap.plan, start, goal), repeat):9.1f}"
        except PlanningError:
            prm_query = "  no path"
        print(
            f"{name:28s} {grid.width * grid.height:8d} {build:7.1f}ms {astar:7.1f}ms {expanded:9d} "
            f"{prm_build:8.1f}ms {prm_query}ms {config.node_count:6d}"
        )


# -- 3 and 4: closed loops, as amr_evaluation episodes -----------------------------------------------------


def plan_follow_spec(world: dict, goal, noise: float, seed: int, resolution: float = LOOP_RESOLUTION) -> EpisodeSpec:
    return EpisodeSpec(
        "plan_follow",
        PLAN_LABEL,
        PLAN_PARAMS,
        world,
        goal,
        seed,
        noise,
        0.0,
        0.0,
        FOLLOW_LIMIT,
        {"resolution": resolution},
    )


def wall_follow_spec(world: dict, noise: float, seed: int) -> EpisodeSpec:
    return EpisodeSpec("wall_follower", WALL_LABEL, WALL_PARAMS, world, None, seed, noise, 0.0, 0.0, WALL_LIMIT)


def shipped_specs() -> list[tuple[str, float, EpisodeSpec]]:
    """(world, map resolution, spec): each shipped world's goal, or its far free point on the 0.05 m map."""
    specs = []
    for path in WORLDS:
        world = load_world(path)
        goal = None
        if world.goal is None:  # a far free point as the goal
            costmap = Costmap(rasterize_world(world, RESOLUTION))
            x, y = far_free_point(costmap, (world.start.x, world.start.y))
            goal = [float(x), float(y), 0.1]
        for resolution in (RESOLUTION, LOOP_RESOLUTION):
            specs.append((path.stem, resolution, plan_follow_spec({"file": path.name}, goal, 0.01, 0, resolution)))
    return specs


def maze_specs(seeds: int) -> list[tuple[str, int, dict, float, str, EpisodeSpec]]:
    """(family, seed, options, noise, goal kind, spec) of plan + follow to the family's goal and a random one."""
    specs = []
    for family in FAMILIES:
        for seed in range(seeds):
            options, _, noise, _ = maze_variant(family, seed)
            world = {"family": family, "seed": seed, "options": options}
            for kind, goal in (("family", None), ("random", "random")):
                specs.append((family, seed, options, noise, kind, plan_follow_spec(world, goal, noise, seed)))
    return specs


def shipped_worlds(rows, records) -> None:
    print("\n== Path following from the true pose on the shipped worlds (LiDAR noise 0.01 m)")
    for name, resolution, spec in rows:
        r = records[spec.key]
        cross = "-" if r["cross_track"] is None else f"{100 * r['cross_track']:.2f}"
        message = r["extra"].get("message", "") if not r["error"] else r["error"]
        print(
            f"{name:16s} map {resolution} m: reached={r['goal_reached']} t={r['time'] or math.nan:6.1f} s "
            f"collisions={r['collisions']} mean cross-track={cross} cm {message}"
        )


def generated_mazes(rows, records, seeds: int, elapsed: float) -> None:
    print("\n== Plan + follow from the true pose on generated mazes, against the wall follower alone")
    runs, comparisons, failures, cross_tracks = [], [], [], []
    for family, seed, options, noise, kind, spec in rows:
        run = records[spec.key]
        runs.append((family, kind, run))
        if run["cross_track"] is not None:
            cross_tracks.append(run["cross_track"])
        if not run["goal_reached"] or run["collisions"]:
            message = run["error"] or run["extra"].get("message", "")
            failures.append(
                f"{family} seed {seed} width {options.get('width', '-')} noise {noise} {kind} goal: "
                f"reached={run['goal_reached']} collisions={run['collisions']} {message}"
            )
        if kind == "family":
            wall = records[wall_follow_spec(spec.world, noise, seed).key]
            if run["goal_reached"] and wall["goal_reached"]:
                comparisons.append((family, run["time"], wall["time"]))
    total = len(runs)
    reached = sum(bool(r["goal_reached"]) for _, _, r in runs)
    clean = sum(r["collisions"] == 0 for _, _, r in runs)
    faster = sum(p < w for _, p, w in comparisons)
    print(
        f"{total} runs over {len(FAMILIES)} families x {seeds} seeds x 2 goals ({elapsed:.0f} s wall clock for "
        "every closed-loop episode, the wall follower alone's included)"
    )
    for family in FAMILIES:
        mine = [r for f, _, r in runs if f == family]
        times = [(p, w) for f, p, w in comparisons if f == family]
        ratio = statistics.median([w / p for p, w in times]) if times else math.nan
        print(
            f"  {family:11s} reached {sum(bool(r['goal_reached']) for r in mine)}/{len(mine)}, collision-free "
            f"{sum(r['collisions'] == 0 for r in mine)}/{len(mine)}, both solve {len(times)}, "
            f"median wall-follower time / plan+follow time {ratio:.2f}"
        )
    print(f"reached: {reached}/{total} = {100 * reached / total:.1f} % (target >= 98 %)")
    print(f"collision-free: {clean}/{total} = {100 * clean / total:.1f} % (target 100 %)")
    if comparisons:
        print(
            f"faster than the wall follower: {faster}/{len(comparisons)} = {100 * faster / len(comparisons):.1f} % "
            f"of the worlds both solve (target >= 90 %)"
        )
    if cross_tracks:
        print(f"mean cross-track error over the runs: {100 * statistics.mean(cross_tracks):.2f} cm")
    replanned = [r["plans"] - 1 for _, _, r in runs if (r["plans"] or 0) > 1]
    print(f"runs that replanned after a block: {len(replanned)} ({sum(replanned)} replans)")
    for line in failures:
        print("  not reached / collided:", line)


def closed_loops(seeds: int, jobs: int, scheduler: str | None, results: str | None) -> None:
    shipped = shipped_specs()
    mazes = maze_specs(seeds)
    walls = [wall_follow_spec(spec.world, noise, seed) for _, seed, _, noise, kind, spec in mazes if kind == "family"]
    specs = [spec for *_, spec in shipped] + [spec for *_, spec in mazes] + walls
    if results is None:
        out = ROOT / "out" / "bench"
        out.mkdir(parents=True, exist_ok=True)
        results = Path(tempfile.mkdtemp(prefix="planning_", dir=out)) / "records.jsonl"
    print(
        f"\n{len(specs)} closed-loop episodes on {f'Dask at {scheduler}' if scheduler else f'{jobs} process(es)'}; "
        f"records in {results}"
    )
    began = time.perf_counter()
    records = dict(
        zip((s.key for s in specs), run_sweep(specs, results, workers=jobs, scheduler=scheduler), strict=True)
    )
    elapsed = time.perf_counter() - began
    shipped_worlds(shipped, records)
    generated_mazes(mazes, records, seeds, elapsed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=6, help="generated mazes per family")
    parser.add_argument("--repeat", type=int, default=20, help="timed runs per planning case")
    parser.add_argument("--quick", action="store_true", help="2 seeds, 5 repeats")
    parser.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="closed loops: local processes")
    parser.add_argument("--scheduler", help="closed loops: a Dask scheduler address (tcp://host:8786)")
    parser.add_argument("--results", help="closed loops: records file (JSON lines), kept and resumed from")
    parser.add_argument("--no-timing", action="store_true", help="only the closed loops (3 and 4)")
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.repeat = 2, 5
    if not args.no_timing:
        planning_times(args.repeat)
    closed_loops(args.seeds, args.jobs, args.scheduler, args.results)


if __name__ == "__main__":
    main()
