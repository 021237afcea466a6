"""Wall follower on generated maze families (issue 14): goal, time, collisions, stalls, states, wall error.

Every family of amr_simulation.maze_families, several seeds, both shipped configurations, at
LiDAR noise 0.01-0.03 m with encoder noise 0.02 and slip 0.05; the goal is always one the
configured hand reaches (maze_families.goal_reachable) within maze_families.WALK_BUDGET m of
boundary walk (36 m: 360 s at 0.1 m/s); "walk" is that length, "v walk" walk / time to goal.
The real-robot configuration runs as on a TurtleBot3: 360 beams (LDS-01) and, with
--lds-rate, a scan every 0.2 s with the command held in between. Library closed loop (bench/wall_follower_runs.py), 600 s per run.

    python bench/bench_wall_follower_families.py [--seeds 5] [--noise 0.01 0.02 0.03]
        [--families perfect bends ...] [--configs sim real] [--jobs 2] [--outliers 0.002] [--png DIR]
    python bench/bench_wall_follower_families.py --shipped   # the shipped worlds, as README's table
    python bench/bench_wall_follower_families.py --route [--mazes 12] [--run-seeds 3] [--jobs 2]

--route (issue 20): tree mazes (perfect, rotated and thin_walls without loops, dead_ends), 6, 7
or 8 m across with 0.35, 0.4 or 0.45 m corridors by seed; on each, the noise-free sim run is the
reference, and the sim config at LiDAR noise 0.03 m with encoder noise 0.02 and slip 0.05 (several
run seeds), the real config noise-free and noisy, are compared with it cell by cell
(amr_simulation.maze_route: the cells entered, a cell counting once the robot's centre is 5 cm
inside it), and every run with the ideal hand tour of the maze's grid. See docs/wall_follower_route.md.
"""

from __future__ import annotations

import argparse
import itertools
import math
import statistics
import sys
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from amr_control.wall_follower_config import read_parameter_file  # noqa: E402
from amr_simulation.maze_families import FAMILIES, generate, walk_length  # noqa: E402
from amr_simulation.maze_route import MazeGrid, cell_route, first_difference, hand_tour  # noqa: E402
from amr_simulation.world import load_world, world_from_dict  # noqa: E402
from wall_follower_runs import RunResult, run  # noqa: E402

CONFIGS = {"sim": ROOT / "config" / "wall_follower_sim.yaml", "real": ROOT / "config" / "wall_follower_real.yaml"}
SHIPPED = ("hard_maze", "inner_maze", "open_room", "outer_corridor")
STATES = ("SEARCH", "FOLLOW", "CORNER", "APPROACH", "TURN_LEFT", "TURN_RIGHT", "TURN_AROUND", "STABILIZE", "AVOID")


def one(job: tuple) -> tuple[tuple, RunResult, float]:
    family, seed, config_name, noise, seconds, lds_rate, outliers, png = job
    config = read_parameter_file(CONFIGS[config_name])
    data = generate(family, seed, hand=config.preferred_wall)
    world = world_from_dict(data, default_name=f"{family}_{seed}")
    real = config_name == "real"
    render = str(Path(png) / f"{family}_{seed}_{config_name}_{noise}.png") if png else None
    result = run(world, config, seconds, lidar_noise=noise, encoder_noise=0.02, slip=0.05, seed=seed,
                 beams=360 if real else 240, scan_period=0.2 if real and lds_rate else None, outlier_rate=outliers,
                 render_path=render)
    return job, result, walk_length(data, config.preferred_wall)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--families", nargs="+", default=list(FAMILIES), choices=FAMILIES)
    parser.add_argument("--seeds", type=int, default=5, help="seeds per family (0..n-1)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--noise", type=float, nargs="+", default=[0.01, 0.02, 0.03], help="LiDAR sigma, m")
    parser.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS))
    parser.add_argument("--seconds", type=float, default=600.0)
    parser.add_argument("--lds-rate", action="store_true", help="real config: a scan every 0.2 s (LDS-01, 5 Hz)")
    parser.add_argument("--outliers", type=float, default=0.0, help="per-beam probability of a spurious return")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--failures", action="store_true", help="list every run that missed its goal")
    parser.add_argument("--png", help="directory: save every run's trajectory there as a PNG")
    parser.add_argument("--shipped", action="store_true",
                        help="instead: the shipped worlds, sim config, LiDAR noise 0.01, no encoder noise")
    parser.add_argument("--route", action="store_true",
                        help="instead: routes in tree mazes compared with the noise-free run (issue 20)")
    parser.add_argument("--mazes", type=int, default=12, help="--route: mazes per family (seeds first-seed..)")
    parser.add_argument("--route-families", nargs="+", default=list(ROUTE_FAMILIES), choices=ROUTE_FAMILIES)
    parser.add_argument("--run-seeds", type=int, default=3, help="--route: noisy sim runs per maze")
    args = parser.parse_args()
    if args.shipped:
        shipped(args.seconds)
        return
    if args.route:
        routes(args)
        return

    jobs = list(itertools.product(args.families, range(args.first_seed, args.first_seed + args.seeds), args.configs,
                                  args.noise, [args.seconds], [args.lds_rate], [args.outliers], [args.png]))
    if args.png:
        Path(args.png).mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    with ProcessPoolExecutor(args.jobs) as pool:
        results = list(pool.map(one, jobs))
    elapsed = time.monotonic() - started

    groups: dict[tuple, list[tuple]] = defaultdict(list)
    for job, result, walk in results:
        groups[(job[0], job[2])].append((job, result, walk))
    print(f"{len(results)} runs, {elapsed:.0f} s wall clock, {args.jobs} job(s); noise {args.noise} m, encoder noise 0.02, "
          f"slip 0.05, outliers {args.outliers}/beam, {args.seconds:.0f} s max, real config at "
          f"{'5 Hz scans, 360 beams' if args.lds_rate else '20 Hz, 360 beams'}")
    print(f"{'family':11s} {'config':6s} {'goal':>7s} {'t mean':>7s} {'t max':>6s} {'coll':>4s} {'stall':>5s} "
          f"{'v m/s':>6s} {'walk':>5s} {'v walk':>6s} {'err run':>7s} {'err fol':>7s}  time in state (%: search follow corner approach "
          f"turnL turnR around stab avoid)")
    totals: dict[str, list] = defaultdict(list)
    for (family, config_name), rows in groups.items():
        reached = [r for _, r, _ in rows if r.goal]
        times = [r.time for r in reached]
        walk_speeds = [w / r.time for _, r, w in rows if r.goal]
        share = {s: statistics.mean(r.state_time.get(s, 0.0) for _, r, _ in rows) * 100 for s in STATES}
        print(f"{family:11s} {config_name:6s} {len(reached):3d}/{len(rows):<3d} "
              f"{statistics.mean(times) if times else math.nan:7.1f} {max(times) if times else math.nan:6.1f} "
              f"{sum(r.collisions for _, r, _ in rows):4d} {sum(r.stalls for _, r, _ in rows):5d} "
              f"{statistics.mean(r.mean_speed for _, r, _ in rows):6.3f} "
              f"{statistics.mean(w for _, _, w in rows):5.1f} {_nanmean(walk_speeds):6.3f} "
              f"{statistics.mean(r.wall_error_run for _, r, _ in rows):7.3f} "
              f"{_nanmean([r.wall_error_following for _, r, _ in rows]):7.3f}  "
              + " ".join(f"{share[s]:4.0f}" for s in STATES))
        totals[config_name] += [r for _, r, _ in rows]
        if args.failures:
            for job, r, walk in rows:
                if not r.goal or r.collisions:
                    print(f"    miss: {job[0]} seed {job[1]} noise {job[3]}: walk {walk:.1f} m, t={r.time:.0f} s "
                          f"collisions={r.collisions} "
                          f"stalls={r.stalls} states " + " ".join(f"{k}={v*100:.0f}" for k, v in r.state_time.items()))
    for config_name, rows in totals.items():
        print(f"TOTAL {config_name}: goal {sum(bool(r.goal) for r in rows)}/{len(rows)} "
              f"({100 * sum(bool(r.goal) for r in rows) / len(rows):.1f} %), collisions {sum(r.collisions for r in rows)}, "
              f"stalls {sum(r.stalls for r in rows)}, wall error run {statistics.mean(r.wall_error_run for r in rows):.3f} m, "
              f"following {_nanmean([r.wall_error_following for r in rows]):.3f} m")


def shipped(seconds: float) -> None:
    """README's closed-loop table: goal, time, collisions, mean speed, wall error per shipped world."""
    config = read_parameter_file(CONFIGS["sim"])
    print(f"shipped worlds, sim config, LiDAR noise 0.01 m, {seconds:.0f} s max")
    for name in SHIPPED:
        r = run(load_world(ROOT / "config" / "worlds" / f"{name}.yaml"), config, seconds, lidar_noise=0.01)
        goal = "no goal" if r.goal is None else f"goal {'reached' if r.goal else 'missed'}"
        print(f"{name:15s} {goal:13s} t={r.time:6.1f} s  collisions {r.collisions}  speed {r.mean_speed:.3f} m/s  "
              f"wall error following {r.wall_error_following * 1000:.1f} mm, whole run {r.wall_error_run * 1000:.1f} mm")


ROUTE_FAMILIES = ("perfect", "rotated", "thin_walls", "dead_ends")
ROUTE_WIDTHS = (0.35, 0.4, 0.45)
ROUTE_SIZES = (6.0, 7.0, 8.0)
ROUTE_NOISE = 0.03


def tree_maze(family: str, seed: int) -> dict:
    """A tree maze of the family: 6, 7 or 8 m across, 0.35, 0.4 or 0.45 m corridors, by seed."""
    options = {"size": ROUTE_SIZES[(seed // len(ROUTE_WIDTHS)) % len(ROUTE_SIZES)],
               "width": ROUTE_WIDTHS[seed % len(ROUTE_WIDTHS)]}
    if family in ("rotated", "thin_walls"):
        options["loop_fraction"] = 0.0
    return generate(family, seed, **options)


def route_run(job: tuple) -> tuple[tuple, RunResult, list]:
    """One run of --route: (family, maze seed, config, LiDAR noise, run seed, seconds, 5 Hz scans)."""
    family, maze, config_name, noise, seed, seconds, lds_rate = job
    data = tree_maze(family, maze)
    config = read_parameter_file(CONFIGS[config_name])
    real = config_name == "real"
    motion = (0.02, 0.05) if noise > 0.0 else (0.0, 0.0)
    result = run(world_from_dict(data, default_name=f"{family}_{maze}"), config, seconds, lidar_noise=noise,
                 encoder_noise=motion[0], slip=motion[1], seed=seed, beams=360 if real else 240,
                 scan_period=0.2 if real and lds_rate else None)
    route = cell_route(MazeGrid.from_world(data), result.path)
    result.path = None  # not needed past here (and large to send between processes)
    return job, result, route


def routes(args: argparse.Namespace) -> None:
    """Issue 20: does the route depend on noise? Cell routes compared with the noise-free sim run's."""
    kinds = [("sim", 0.0, 0)] + [("sim", ROUTE_NOISE, s + 1) for s in range(args.run_seeds)]
    if "real" in args.configs:
        kinds += [("real", 0.0, 0), ("real", ROUTE_NOISE, 1)]
    mazes = [(f, m) for f in args.route_families for m in range(args.first_seed, args.first_seed + args.mazes)]
    jobs = [(f, m, c, n, s, args.seconds, args.lds_rate) for f, m in mazes for c, n, s in kinds]
    started = time.monotonic()
    with ProcessPoolExecutor(args.jobs) as pool:
        results = {(job[0], job[1], job[2], job[3], job[4]): (result, route)
                   for job, result, route in pool.map(route_run, jobs)}
    elapsed = time.monotonic() - started
    print(f"routes: {len(mazes)} tree mazes ({', '.join(args.route_families)}; 6-8 m, corridors 0.35-0.45 m), "
          f"{len(jobs)} runs, {elapsed:.0f} s wall clock, {args.jobs} job(s); noisy = LiDAR {ROUTE_NOISE} m, encoder "
          f"noise 0.02, slip 0.05; real config 360 beams at {'5 Hz' if args.lds_rate else '20 Hz'}; "
          f"{args.seconds:.0f} s max")
    print("same: the run's cells = the noise-free sim run's, up to the shorter's end; tour: the run's cells are "
          "the maze's ideal hand tour from the start; goal reached, collisions, mean time to goal")
    print(f"{'config':6s} {'noise':>5s} {'runs':>4s} {'same':>9s} {'tour':>9s} {'goal':>9s} {'coll':>4s} {'t goal':>6s}")
    differences = []
    for config_name, noise, _ in dict.fromkeys((c, n, 0) for c, n, _ in kinds):
        rows = [(key, *value) for key, value in results.items() if key[2] == config_name and key[3] == noise]
        same = tour_ok = 0
        for key, result, route in rows:
            reference = results[(key[0], key[1], "sim", 0.0, 0)][1]
            data = tree_maze(key[0], key[1])
            tour = hand_tour(MazeGrid.from_world(data), data["start"], read_parameter_file(CONFIGS["sim"]).preferred_wall)
            shorter = min(len(route), len(reference))
            at = first_difference(route[:shorter], reference[:shorter])
            on_tour = first_difference(route, tour)
            same += at is None
            tour_ok += on_tour is None
            if at is not None or on_tour is not None or not result.goal or result.collisions:
                differences.append((key, result, route, reference, tour, at, on_tour))
        goals = [r.time for _, r, _ in rows if r.goal]
        n = len(rows)
        print(f"{config_name:6s} {noise:5.2f} {n:4d} {same:4d} {100 * same / n:3.0f}% {tour_ok:4d} {100 * tour_ok / n:3.0f}% "
              f"{len(goals):4d} {100 * len(goals) / n:3.0f}% {sum(r.collisions for _, r, _ in rows):4d} "
              f"{statistics.mean(goals) if goals else math.nan:6.1f}")
    for key, result, route, reference, tour, at, on_tour in differences:
        where = "" if on_tour is None else (
            f"; leaves the tour at cell {on_tour}: {route[on_tour - 1]} -> "
            f"{route[on_tour] if on_tour < len(route) else '(end)'}, the tour goes to {tour[on_tour] if on_tour < len(tour) else '(end)'}")
        print(f"    {key[0]} {key[1]} {key[2]} noise {key[3]} seed {key[4]}: goal {'reached' if result.goal else 'missed'} "
              f"at {result.time:.0f} s, {len(route)} cells, collisions {result.collisions}, "
              f"{'same as noise-free' if at is None else f'differs from noise-free at cell {at}'}{where}")


def _nanmean(values: list[float]) -> float:
    kept = [v for v in values if not math.isnan(v)]
    return statistics.mean(kept) if kept else math.nan


if __name__ == "__main__":
    main()
