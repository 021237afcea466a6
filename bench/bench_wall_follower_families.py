"""Wall follower on generated maze families: goal, time, collisions, stalls, states, wall error.

Every family of amr_maps.maze_families, several seeds, both shipped configurations, at
LiDAR noise 0.01-0.03 m with encoder noise 0.02 and slip 0.05; the goal is always one the
configured hand reaches (maze_families.goal_reachable) within maze_families.WALK_BUDGET m of
boundary walk (36 m: 360 s at 0.1 m/s); "walk" is that length, "v walk" walk / time to goal.
The real-robot configuration runs as on a TurtleBot3: 360 beams (LDS-01) and, with
--lds-rate, a scan every 0.2 s with the command held in between. Library closed loop
(amr_evaluation/wall_follower_loop.py), 600 s per run.

Every run is an amr_evaluation episode (controller wall_follower) run by its runner: --jobs N local processes,
--scheduler tcp://host:8786 a Dask cluster, --results FILE keeps the records and resumes from them (default:
a fresh file in out/bench/). --png re-runs each episode in this process to draw it.

    python bench/bench_wall_follower_families.py [--seeds 5] [--noise 0.01 0.02 0.03]
        [--families perfect bends ...] [--configs sim real] [--jobs 2] [--scheduler tcp://host:8786]
        [--outliers 0.002] [--png DIR]
    python bench/bench_wall_follower_families.py --shipped   # the shipped worlds, as README's table
    python bench/bench_wall_follower_families.py --route [--mazes 6] [--run-seeds 3] [--jobs 2]

--route (the route must not depend on noise): tree mazes (perfect; rotated and thin_walls
without loops; dead_ends), 6, 7 or 8 m across with 0.35, 0.4 or 0.45 m corridors by maze seed. On each,
the noise-free sim run is the reference; the sim config at LiDAR noise 0.03 m with encoder noise 0.02
and slip 0.05 (--run-seeds seeds) and the real config (noise-free and noisy) are compared with it cell by
cell (amr_maps.maze_route.cell_route: the cells entered, a cell counting once the robot's centre is
5 cm inside it), and every run with the maze's ideal hand tour (amr_maps.maze_route.hand_tour).
"""

from __future__ import annotations

import argparse
import math
import statistics
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from amr_evaluation import configs
from amr_evaluation.episode import EpisodeSpec, wall_follower_config
from amr_evaluation.runner import run_sweep
from amr_evaluation.wall_follower_loop import run
from amr_evaluation.worlds import build_world, world_dict
from amr_maps.maze_families import FAMILIES, walk_length
from amr_maps.maze_route import MazeGrid, first_difference, hand_tour

ROOT = Path(__file__).resolve().parents[1]

CONFIGS = ("sim", "real")
SHIPPED = ("hard_maze", "inner_maze", "open_room", "outer_corridor")
STATES = ("SEARCH", "FOLLOW", "CORNER", "APPROACH", "TURN_LEFT", "TURN_RIGHT", "TURN_AROUND", "STABILIZE", "AVOID")


def spec_of(
    family: str, seed: int, config_name: str, noise: float, seconds: float, lds_rate: bool, outliers: float
) -> EpisodeSpec:
    label, parameters = configs.resolve("wall_follower", config_name)
    real = config_name == "real"
    options = {"beams": 360 if real else 240}
    if real and lds_rate:
        options["scan_period"] = 0.2
    if outliers:
        options["outlier_rate"] = outliers
    world = {"family": family, "seed": seed, "options": {"hand": parameters["wall_follower"]["preferred_wall"]}}
    return EpisodeSpec("wall_follower", label, parameters, world, None, seed, noise, 0.02, 0.05, seconds, options)


def draw(spec: EpisodeSpec, directory: Path) -> None:
    """The episode again, in this process, with its picture (the runner's episodes draw nothing)."""
    path = directory / f"{spec.world['family']}_{spec.seed}_{spec.config}_{spec.lidar_noise}.png"
    run(
        build_world(spec.world),
        wall_follower_config(spec),
        spec.duration,
        lidar_noise=spec.lidar_noise,
        encoder_noise=spec.encoder_noise,
        slip=spec.slip,
        seed=spec.seed,
        beams=spec.options.get("beams", 240),
        scan_period=spec.options.get("scan_period"),
        outlier_rate=spec.options.get("outlier_rate", 0.0),
        render_path=str(path),
    )


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
    parser.add_argument("--scheduler", help="a Dask scheduler address (tcp://host:8786) instead of local processes")
    parser.add_argument("--results", help="records file (JSON lines): kept, and a run resumes from it")
    parser.add_argument("--failures", action="store_true", help="list every run that missed its goal")
    parser.add_argument("--png", help="directory: save every run's trajectory there as a PNG")
    parser.add_argument(
        "--shipped",
        action="store_true",
        help="instead: the shipped worlds, sim config, LiDAR noise 0.01, no encoder noise",
    )
    parser.add_argument(
        "--route",
        action="store_true",
        help="instead: routes through tree mazes compared with the noise-free run's",
    )
    parser.add_argument("--mazes", type=int, default=6, help="--route: mazes per family (seeds first-seed..)")
    parser.add_argument("--route-families", nargs="+", default=list(ROUTE_FAMILIES), choices=ROUTE_FAMILIES)
    parser.add_argument("--run-seeds", type=int, default=3, help="--route: noisy sim runs per maze")
    args = parser.parse_args()
    results = Path(args.results) if args.results else _fresh_results()
    if args.shipped:
        shipped(args.seconds, results, args.jobs, args.scheduler)
        return
    if args.route:
        routes(args, results)
        return

    jobs = [
        (family, seed, config_name, noise)
        for family in args.families
        for seed in range(args.first_seed, args.first_seed + args.seeds)
        for config_name in args.configs
        for noise in args.noise
    ]
    specs = [spec_of(*job, args.seconds, args.lds_rate, args.outliers) for job in jobs]
    started = time.monotonic()
    records = run_sweep(specs, results, workers=args.jobs, scheduler=args.scheduler)
    elapsed = time.monotonic() - started
    if args.png:
        Path(args.png).mkdir(parents=True, exist_ok=True)
        for spec in specs:
            draw(spec, Path(args.png))
    walks = {}
    for spec in specs:
        hand = spec.world["options"]["hand"]
        key = (spec.world["family"], spec.world["seed"], hand)
        if key not in walks:
            walks[key] = walk_length(world_dict(spec.world), hand)
    failed = [r for r in records if r["error"]]
    for record in failed:
        print(f"episode {record['world']} {record['config']} noise {record['lidar_noise']} raised: {record['error']}")
    rows_of = [
        (job, r, walks[(r["family"], r["world_seed"], r["extra"].get("preferred_wall", "right"))])
        for job, r in zip(jobs, records, strict=True)
        if not r["error"]
    ]

    groups: dict[tuple, list[tuple]] = defaultdict(list)
    for job, r, walk in rows_of:
        groups[(job[0], job[2])].append((job, r, walk))
    where = f"Dask at {args.scheduler}" if args.scheduler else f"{args.jobs} job(s)"
    print(
        f"{len(records)} runs, {elapsed:.0f} s wall clock, {where}; noise {args.noise} m, encoder noise 0.02, "
        f"slip 0.05, outliers {args.outliers}/beam, {args.seconds:.0f} s max, real config at "
        f"{'5 Hz scans, 360 beams' if args.lds_rate else '20 Hz, 360 beams'}; records in {results}"
    )
    print(
        f"{'family':11s} {'config':6s} {'goal':>7s} {'t mean':>7s} {'t max':>6s} {'coll':>4s} {'stall':>5s} "
        f"{'v m/s':>6s} {'walk':>5s} {'v walk':>6s} {'err run':>7s} {'err fol':>7s}  "
        f"time in state (%: search follow corner approach turnL turnR around stab avoid)"
    )
    totals: dict[str, list] = defaultdict(list)
    for (family, config_name), rows in groups.items():
        reached = [r for _, r, _ in rows if r["goal_reached"]]
        times = [r["time"] for r in reached]
        walk_speeds = [w / r["time"] for _, r, w in rows if r["goal_reached"]]
        share = {s: statistics.mean(r["extra"]["state_time"].get(s, 0.0) for _, r, _ in rows) * 100 for s in STATES}
        print(
            f"{family:11s} {config_name:6s} {len(reached):3d}/{len(rows):<3d} "
            f"{statistics.mean(times) if times else math.nan:7.1f} {max(times) if times else math.nan:6.1f} "
            f"{sum(r['collisions'] for _, r, _ in rows):4d} {sum(r['stalls'] for _, r, _ in rows):5d} "
            f"{statistics.mean(r['mean_speed'] for _, r, _ in rows):6.3f} "
            f"{statistics.mean(w for _, _, w in rows):5.1f} {_nanmean(walk_speeds):6.3f} "
            f"{_nanmean([r['wall_error_run'] for _, r, _ in rows]):7.3f} "
            f"{_nanmean([r['wall_error_following'] for _, r, _ in rows]):7.3f}  "
            + " ".join(f"{share[s]:4.0f}" for s in STATES)
        )
        totals[config_name] += [r for _, r, _ in rows]
        if args.failures:
            for job, r, walk in rows:
                if not r["goal_reached"] or r["collisions"]:
                    print(
                        f"    miss: {job[0]} seed {job[1]} noise {job[3]}: walk {walk:.1f} m, t={r['time']:.0f} s "
                        f"collisions={r['collisions']} stalls={r['stalls']} states "
                        + " ".join(f"{k}={v * 100:.0f}" for k, v in r["extra"]["state_time"].items())
                    )
    for config_name, rows in totals.items():
        goals = sum(bool(r["goal_reached"]) for r in rows)
        print(
            f"TOTAL {config_name}: goal {goals}/{len(rows)} ({100 * goals / len(rows):.1f} %), "
            f"collisions {sum(r['collisions'] for r in rows)}, stalls {sum(r['stalls'] for r in rows)}, "
            f"wall error run {_nanmean([r['wall_error_run'] for r in rows]):.3f} m, "
            f"following {_nanmean([r['wall_error_following'] for r in rows]):.3f} m"
        )


def shipped(seconds: float, results: Path, jobs: int, scheduler: str | None) -> None:
    """README's closed-loop table: goal, time, collisions, mean speed, wall error per shipped world."""
    label, parameters = configs.resolve("wall_follower", "sim")
    specs = [
        EpisodeSpec("wall_follower", label, parameters, {"file": f"{name}.yaml"}, None, 0, 0.01, 0.0, 0.0, seconds)
        for name in SHIPPED
    ]
    print(f"shipped worlds, sim config, LiDAR noise 0.01 m, {seconds:.0f} s max")
    for name, r in zip(
        SHIPPED, run_sweep(specs, results, workers=jobs, scheduler=scheduler, progress=False), strict=True
    ):
        goal = "no goal" if r["goal_reached"] is None else f"goal {'reached' if r['goal_reached'] else 'missed'}"
        print(
            f"{name:15s} {goal:13s} t={r['time']:6.1f} s  collisions {r['collisions']}  "
            f"speed {r['mean_speed']:.3f} m/s  wall error following {r['wall_error_following'] * 1000:.1f} mm, "
            f"whole run {r['wall_error_run'] * 1000:.1f} mm"
        )


ROUTE_FAMILIES = ("perfect", "rotated", "thin_walls", "dead_ends")
ROUTE_WIDTHS = (0.35, 0.4, 0.45)
ROUTE_SIZES = (6.0, 7.0, 8.0)
ROUTE_NOISE = 0.03


def tree_maze(family: str, seed: int, hand: str) -> dict:
    """The world spec of a tree maze: 6, 7 or 8 m across and 0.35, 0.4 or 0.45 m corridors, by seed."""
    options = {
        "size": ROUTE_SIZES[(seed // len(ROUTE_WIDTHS)) % len(ROUTE_SIZES)],
        "width": ROUTE_WIDTHS[seed % len(ROUTE_WIDTHS)],
        "hand": hand,
    }
    if family in ("rotated", "thin_walls"):
        options["loop_fraction"] = 0.0
    return {"family": family, "seed": seed, "options": options}


def routes(args: argparse.Namespace, results: Path) -> None:
    """Does the route depend on noise? Cell routes compared with the noise-free sim run's."""
    kinds = [("sim", 0.0, 0)] + [("sim", ROUTE_NOISE, s + 1) for s in range(args.run_seeds)]
    if "real" in args.configs:
        kinds += [("real", 0.0, 0), ("real", ROUTE_NOISE, 1)]
    mazes = [(f, m) for f in args.route_families for m in range(args.first_seed, args.first_seed + args.mazes)]
    specs, keys = [], []
    for family, maze in mazes:
        for config_name, noise, seed in kinds:
            label, parameters = configs.resolve("wall_follower", config_name)
            real = config_name == "real"
            options = {"beams": 360 if real else 240, "route": True}
            if real and args.lds_rate:
                options["scan_period"] = 0.2
            world = tree_maze(family, maze, parameters["wall_follower"]["preferred_wall"])
            motion = (0.02, 0.05) if noise > 0.0 else (0.0, 0.0)
            specs.append(
                EpisodeSpec(
                    "wall_follower", label, parameters, world, None, seed, noise, *motion, args.seconds, options
                )
            )
            keys.append((family, maze, config_name, noise, seed))
    started = time.monotonic()
    records = dict(zip(keys, run_sweep(specs, results, workers=args.jobs, scheduler=args.scheduler), strict=True))
    elapsed = time.monotonic() - started
    where = f"Dask at {args.scheduler}" if args.scheduler else f"{args.jobs} job(s)"
    print(
        f"routes: {len(mazes)} tree mazes ({', '.join(args.route_families)}; 6-8 m, corridors 0.35-0.45 m), "
        f"{len(specs)} runs, {elapsed:.0f} s wall clock, {where}; noisy = LiDAR {ROUTE_NOISE} m, encoder noise "
        f"0.02, slip 0.05; real config 360 beams at {'5 Hz' if args.lds_rate else '20 Hz'}; {args.seconds:.0f} s "
        f"max; records in {results}"
    )
    print(
        "same: the run's cells = the noise-free sim run's (up to where the shorter ends at its goal); tour: the "
        "run's cells follow the maze's ideal hand tour; goal: reached within the time; coll: collisions"
    )
    print(
        f"{'config':6s} {'noise':>5s} {'runs':>4s} {'same':>7s} {'tour':>7s} {'goal':>7s} {'coll':>4s} {'t goal':>6s}"
    )
    tours = {}
    for family, maze in mazes:
        spec = next(s for s, k in zip(specs, keys, strict=True) if k[:2] == (family, maze))
        data = world_dict(spec.world)
        tours[(family, maze)] = hand_tour(MazeGrid.from_world(data), data["start"], spec.world["options"]["hand"])
    notes = []
    for config_name, noise in dict.fromkeys((c, n) for c, n, _ in kinds):
        rows = [(k, r) for k, r in records.items() if k[2] == config_name and k[3] == noise]
        same = on_tour = reached = collisions = 0
        times = []
        for key, r in rows:
            if r["error"]:
                notes.append(f"    {key}: raised {r['error']}")
                continue
            route = [tuple(c) for c in r["extra"]["route"]]
            ref_record = records[(key[0], key[1], "sim", 0.0, 0)]
            reference = [tuple(c) for c in ref_record["extra"].get("route", [])] if not ref_record["error"] else []
            shorter = min(len(route), len(reference))
            at = first_difference(route[:shorter], reference[:shorter])
            off = first_difference(route, tours[key[:2]])
            same += at is None
            on_tour += off is None
            reached += bool(r["goal_reached"])
            collisions += r["collisions"]
            if r["goal_reached"]:
                times.append(r["time"])
            if at is not None or off is not None or not r["goal_reached"] or r["collisions"]:
                tour = tours[key[:2]]
                leaves = (
                    ""
                    if off is None
                    else (
                        f"; leaves the tour after cell {off - 1}: {route[off - 1]} -> "
                        f"{route[off] if off < len(route) else '(end)'} where the tour goes to "
                        f"{tour[off] if off < len(tour) else '(end)'}"
                    )
                )
                notes.append(
                    f"    {key[0]} {key[1]} {config_name} noise {noise} seed {key[4]}: goal "
                    f"{'reached' if r['goal_reached'] else 'missed'} at {r['time']:.0f} s, {len(route)} cells, "
                    f"collisions {r['collisions']}, "
                    f"{'same cells as noise-free' if at is None else f'differs from noise-free at cell {at}'}"
                    f"{leaves}"
                )
        n = len(rows)
        print(
            f"{config_name:6s} {noise:5.2f} {n:4d} {same:3d}/{n:<3d} {on_tour:3d}/{n:<3d} {reached:3d}/{n:<3d} "
            f"{collisions:4d} {statistics.mean(times) if times else math.nan:6.1f}"
        )
    for note in notes:
        print(note)


def _fresh_results() -> Path:
    out = ROOT / "out" / "bench"
    out.mkdir(parents=True, exist_ok=True)
    return Path(tempfile.mkdtemp(prefix="wall_follower_families_", dir=out)) / "records.jsonl"


def _nanmean(values: list) -> float:
    kept = [v for v in values if v is not None and not math.isnan(v)]
    return statistics.mean(kept) if kept else math.nan


if __name__ == "__main__":
    main()
