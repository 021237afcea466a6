"""Wall follower on generated maze families (issue 14): goal, time, collisions, stalls, states, wall error.

Every family of amr_maps.maze_families, several seeds, both shipped configurations, at
LiDAR noise 0.01-0.03 m with encoder noise 0.02 and slip 0.05; the goal is always one the
configured hand reaches (maze_families.goal_reachable) within maze_families.WALK_BUDGET m of
boundary walk (36 m: 360 s at 0.1 m/s); "walk" is that length, "v walk" walk / time to goal.
The real-robot configuration runs as on a TurtleBot3: 360 beams (LDS-01) and, with
--lds-rate, a scan every 0.2 s with the command held in between. Library closed loop (bench/wall_follower_runs.py), 600 s per run.

    python bench/bench_wall_follower_families.py [--seeds 5] [--noise 0.01 0.02 0.03]
        [--families perfect bends ...] [--configs sim real] [--jobs 2] [--outliers 0.002] [--png DIR]
    python bench/bench_wall_follower_families.py --shipped   # the shipped worlds, as bench/README.md's table
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

from wall_follower_runs import RunResult, run  # noqa: E402

from amr_control.wall_follower_config import read_parameter_file  # noqa: E402
from amr_maps.maze_families import FAMILIES, generate, walk_length  # noqa: E402
from amr_maps.world import load_world, world_from_dict  # noqa: E402

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
    args = parser.parse_args()
    if args.shipped:
        shipped(args.seconds)
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
    """bench/README.md's closed-loop table: goal, time, collisions, mean speed, wall error per shipped world."""
    config = read_parameter_file(CONFIGS["sim"])
    print(f"shipped worlds, sim config, LiDAR noise 0.01 m, {seconds:.0f} s max")
    for name in SHIPPED:
        r = run(load_world(ROOT / "config" / "worlds" / f"{name}.yaml"), config, seconds, lidar_noise=0.01)
        goal = "no goal" if r.goal is None else f"goal {'reached' if r.goal else 'missed'}"
        print(f"{name:15s} {goal:13s} t={r.time:6.1f} s  collisions {r.collisions}  speed {r.mean_speed:.3f} m/s  "
              f"wall error following {r.wall_error_following * 1000:.1f} mm, whole run {r.wall_error_run * 1000:.1f} mm")


def _nanmean(values: list[float]) -> float:
    kept = [v for v in values if not math.isnan(v)]
    return statistics.mean(kept) if kept else math.nan


if __name__ == "__main__":
    main()
