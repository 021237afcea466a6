"""The whole navigation loop at library level (no ROS): explore by wall following until the particle
filter says localized, plan from the ESTIMATED pose (A* on the costmap, smoothing), follow with pure
pursuit on the estimated pose, replan when strayed / blocked / the goal changes, explore again if the
filter withdraws `localized` (amr_navigation.loop: the navigator node's own decisions).

Prints per run: when the filter first said localized, the goal reached time or why not, collisions,
mean cross-track error (true pose to the followed path while tracking), and the wall follower alone's
time on the same case (same world, seed, noise, hand). Then: % reached, % collision-free, faster than
the wall follower in X of Y cases both solve. Asserts nothing.

Cases: the shipped worlds with a goal (a few seeds); inner_maze and outer_corridor, which have none,
with their far free point (a 0.1 m goal region there); twin_rooms (symmetric: the filter must never say
localized there, so no goal is expected; reported apart, as are generated worlds whose walls map onto
themselves under a 90 or 180 deg rotation, e.g. plain rectangular open rooms); generated mazes of amr_maps.maze_families
(corridors 0.35 / 0.45 / 0.6 m, LiDAR noise 0 / 0.01 / 0.03 m cycled over the seeds, as bench_planning.py)
with the family's goal (reachable by the wall follower's hand) and a random free goal in the start's
connected free space (often one no wall follower reaches).

Configuration: config/particle_filter.yaml (map rasterized at its 0.02 m), config/planner.yaml (0.025 m),
config/path_follower_sim.yaml, config/wall_follower_sim.yaml (preferred_wall = the family's hand);
encoder noise 0.02 and slip 0.05 (as bench_wall_follower_families.py) unless --encoder-noise/--slip.

Every run is an episode of amr_evaluation (controller `navigation`, and `wall_follower` for the wall
follower alone), run by its runner: `--jobs N` local processes, or `--scheduler tcp://host:8786` on a Dask
cluster; `--results FILE` keeps the records (JSON lines) and resumes from them (default: a fresh file in
out/bench/).

    python bench/bench_navigation.py [--quick] [--seeds 6] [--families perfect,loops] [--jobs 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import tempfile
import time
from pathlib import Path

from amr_evaluation import configs
from amr_evaluation.cases import maze_variant
from amr_evaluation.episode import EpisodeSpec
from amr_evaluation.runner import run_sweep
from amr_evaluation.worlds import build_world
from amr_maps.maze_families import FAMILIES
from amr_maps.world import load_world
from amr_maps.world_symmetry import rotationally_symmetric

ROOT = Path(__file__).resolve().parents[1]

WORLDS = ROOT / "config" / "worlds"
LIMIT = 600.0
MAX_COLLISIONS = 5
NAV_LABEL, NAV_PARAMS = configs.resolve("navigation", "default")
WALL_LABEL, WALL_PARAMS = configs.resolve("wall_follower", "sim")


@dataclasses.dataclass(frozen=True)
class Case:
    label: str
    kind: str  # shipped, shipped far free goal, symmetric, family goal, random goal
    navigation: EpisodeSpec
    wall: EpisodeSpec | None  # the wall follower alone on the same world, seed, noise and hand


def case(
    label: str,
    kind: str,
    world: dict,
    seed: int,
    noise: float,
    goal,
    encoder_noise: float,
    slip: float,
    compare: bool,
    limit: float = LIMIT,
) -> Case:
    navigation = EpisodeSpec(
        "navigation",
        NAV_LABEL,
        NAV_PARAMS,
        world,
        goal,
        seed,
        noise,
        encoder_noise,
        slip,
        limit,
        {"max_collisions": MAX_COLLISIONS},
    )
    wall = (
        EpisodeSpec("wall_follower", WALL_LABEL, WALL_PARAMS, world, goal, seed, noise, encoder_noise, slip, LIMIT)
        if compare
        else None
    )
    return Case(label, kind, navigation, wall)


def shipped_cases(seeds: int, twin_limit: float, encoder_noise: float, slip: float) -> list[Case]:
    cases = []
    for path in sorted(WORLDS.glob("*.yaml")):
        world = load_world(path)
        for seed in range(seeds):
            spec = {"file": path.name}
            if path.stem == "twin_rooms":
                cases.append(
                    case(
                        f"twin_rooms s{seed}",
                        "symmetric",
                        spec,
                        seed,
                        0.01,
                        "far",
                        encoder_noise,
                        slip,
                        compare=False,
                        limit=twin_limit,
                    )
                )
            elif world.goal is not None:
                cases.append(case(f"{path.stem} s{seed}", "shipped", spec, seed, 0.01, None, encoder_noise, slip, True))
            else:
                cases.append(
                    case(
                        f"{path.stem} s{seed}",
                        "shipped, far free goal",
                        spec,
                        seed,
                        0.01,
                        "far",
                        encoder_noise,
                        slip,
                        False,
                    )
                )
    return cases


def maze_cases(families: list[str], seeds: int, random_goals: bool, encoder_noise: float, slip: float) -> list[Case]:
    cases = []
    for family in families:
        for seed in range(seeds):
            options, width, noise, hand = maze_variant(family, seed)
            spec = {"family": family, "seed": seed, "options": options}
            width_label = f"w{width}" if "width" in options else "w-"
            label = f"{family} s{seed} {width_label} n{noise}"
            symmetry = rotationally_symmetric(build_world(spec))
            if symmetry:  # no pose can be told from its rotated image: like twin_rooms, no goal is expected
                cases.append(
                    case(
                        f"{label} (symmetric {symmetry})",
                        "symmetric",
                        spec,
                        seed,
                        noise,
                        None,
                        encoder_noise,
                        slip,
                        compare=False,
                    )
                )
                continue
            cases.append(case(label + " family", "family goal", spec, seed, noise, None, encoder_noise, slip, True))
            if random_goals:  # a random free cell over 1 m from the start, on the planner's costmap
                cases.append(
                    case(
                        label + " random",
                        "random goal",
                        spec,
                        seed,
                        noise,
                        "random",
                        encoder_noise,
                        slip,
                        compare=False,
                    )
                )
    return cases


# -- report -----------------------------------------------------------------------------------


def line(c: Case, run: dict, wall: dict | None) -> str:
    localized = f"{run['time_to_localized']:6.1f}" if run["time_to_localized"] is not None else "     -"
    if run["error"]:
        outcome = f"ERROR {run['error']}"
    else:
        outcome = f"goal {run['time']:6.1f}" if run["goal_reached"] else f"FAIL: {run['reason']} (t={run['time']:.0f})"
        if c.kind == "symmetric" and not run["goal_reached"]:
            outcome = f"no goal expected ({run['reason']})"
    cross = f"{100 * run['cross_track']:5.2f}" if run["cross_track"] is not None else "    -"
    alone = "-" if wall is None else (f"{wall['time']:6.1f}" if wall["goal_reached"] else f"not in {LIMIT:.0f}")
    extra = []
    if run["localization_losses"]:
        extra.append(f"lost {run['localization_losses']}x")
    if (run["plans"] or 0) > 1:
        extra.append(f"{run['plans']} plans")
    if run["planning_failures"]:
        extra.append(f"{run['planning_failures']} planning failures ({run['extra'].get('last_planning_failure')})")
    if run["goal_reached"]:
        extra.append(f"true dist to goal {100 * run['extra']['goal_distance']:.1f} cm")
    error_max = run["localization_error_max"] or 0.0
    return (
        f"{c.label:38s} loc {localized} s  {outcome:28s} coll {run['collisions']}  xte {cross} cm  "
        f"est.err max {100 * error_max:4.1f} cm  wall alone {alone:>10s}  "
        f"[{run['wall_time']:.0f} s] {'; '.join(extra)}"
    )


def summary(title: str, rows: list[tuple[Case, dict, dict | None]]) -> None:
    if not rows:
        return
    total = len(rows)
    reached = [(c, r, w) for c, r, w in rows if r["goal_reached"]]
    claimed = sum(bool(r["extra"].get("follower_reached")) for _, r, _ in rows)
    clean = sum(r["collisions"] == 0 for _, r, _ in rows)
    both = [(r, w) for _, r, w in reached if w is not None and w["goal_reached"]]
    faster = sum(r["time"] < w["time"] for r, w in both)
    crosses = [r["cross_track"] for _, r, _ in rows if r["cross_track"] is not None]
    localized = [r["time_to_localized"] for _, r, _ in rows if r["time_to_localized"] is not None]
    print(f"\n-- {title}: {total} runs")
    print(
        f"reached: {len(reached)}/{total} = {100 * len(reached) / total:.1f} % (target >= 98 %)"
        + (f"; the follower said reached in {claimed}" if claimed > len(reached) else "")
    )
    print(f"collision-free: {clean}/{total} = {100 * clean / total:.1f} % (target 100 %)")
    wall_only = sum(1 for _, _, w in rows if w is not None and w["goal_reached"])
    if wall_only and both:
        ratios = [w["time"] / r["time"] for r, w in both]
        print(
            f"faster than the wall follower alone: {faster}/{len(both)} of the cases both solve "
            f"({100 * faster / len(both):.0f} %, target >= 90 %; the wall follower alone solves {wall_only}); "
            f"median wall-follower time / loop time {statistics.median(ratios):.2f}"
        )
    if localized:
        print(
            f"first localized: median {statistics.median(localized):.1f} s, max {max(localized):.1f} s "
            f"({len(localized)}/{total} localized)"
        )
    if crosses:
        print(
            f"mean cross-track error per run (true pose): median {100 * statistics.median(crosses):.2f} cm, "
            f"max {100 * max(crosses):.2f} cm (target <= 3 cm on the shipped worlds)"
        )
    losses = [r["localization_losses"] for _, r, _ in rows if r["localization_losses"]]
    print(f"runs where the filter withdrew `localized` on the way: {len(losses)} ({sum(losses)} withdrawals)")
    for c, r, w in rows:
        if not r["goal_reached"] or r["collisions"]:
            print("  not reached / collided:", line(c, r, w))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument(
        "--seeds",
        type=int,
        default=9,
        help="generated mazes per family (default 9: every width x noise pair per family)",
    )
    parser.add_argument("--shipped-seeds", type=int, default=3, help="seeds per shipped world (default 3)")
    parser.add_argument("--families", default=",".join(FAMILIES), help="comma-separated maze families (default all)")
    parser.add_argument("--no-random-goals", action="store_true", help="only the families' goals")
    parser.add_argument("--no-shipped", action="store_true")
    parser.add_argument("--twin-limit", type=float, default=120.0, help="s simulated in twin_rooms (default 120)")
    parser.add_argument("--encoder-noise", type=float, default=0.02)
    parser.add_argument("--slip", type=float, default=0.05)
    parser.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    parser.add_argument("--scheduler", help="a Dask scheduler address (tcp://host:8786) instead of local processes")
    parser.add_argument("--results", help="records file (JSON lines): kept, and a run resumes from it")
    parser.add_argument("--quick", action="store_true", help="2 seeds per family, 1 per shipped world, 60 s twin_rooms")
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.shipped_seeds, args.twin_limit = 2, 1, 60.0
    families = [f.strip() for f in args.families.split(",") if f.strip()]
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        parser.error(f"unknown families {unknown} (known: {', '.join(FAMILIES)})")
    cases = [] if args.no_shipped else shipped_cases(args.shipped_seeds, args.twin_limit, args.encoder_noise, args.slip)
    cases += maze_cases(families, args.seeds, not args.no_random_goals, args.encoder_noise, args.slip)
    specs = [c.navigation for c in cases] + [c.wall for c in cases if c.wall is not None]
    results = (
        Path(args.results)
        if args.results
        else Path(tempfile.mkdtemp(prefix="navigation_", dir=_out())) / "records.jsonl"
    )
    where = f"Dask at {args.scheduler}" if args.scheduler else f"{args.jobs} processes"
    print(
        f"{len(cases)} runs ({len(specs)} episodes with the wall follower alone), {where}, encoder noise "
        f"{args.encoder_noise}, slip {args.slip}, limit {LIMIT:.0f} s simulated, stop at {MAX_COLLISIONS} collisions; "
        f"load {os.getloadavg()[0]:.1f}; records in {results}"
    )
    print(
        "columns: first localized (s), goal time or failure, collisions, mean cross-track error (true pose), "
        "largest estimate error while localized, wall follower alone's time [wall-clock s]"
    )
    began = time.perf_counter()
    records = dict(
        zip((s.key for s in specs), run_sweep(specs, results, workers=args.jobs, scheduler=args.scheduler), strict=True)
    )
    rows = [(c, records[c.navigation.key], records[c.wall.key] if c.wall else None) for c in cases]
    for row in rows:
        print(line(*row))
    print(f"\n{time.perf_counter() - began:.0f} s wall clock, load {os.getloadavg()[0]:.1f} at the end")
    for c, run, _ in rows:
        if c.kind == "symmetric":
            print(
                f"symmetric {c.label}, {c.navigation.duration:.0f} s: "
                + (
                    "never localized (as expected)"
                    if run["time_to_localized"] is None
                    else f"FALSE localization at {run['time_to_localized']:.1f} s"
                )
                + (
                    f"; the wall follower passed the goal region while exploring at {run['time']:.1f} s"
                    if run["goal_reached"]
                    else ""
                )
            )
    summary("shipped worlds with a goal", [r for r in rows if r[0].kind == "shipped"])
    summary("shipped worlds without one (far free goal)", [r for r in rows if r[0].kind == "shipped, far free goal"])
    mazes = [r for r in rows if r[0].kind in ("family goal", "random goal")]
    summary("generated mazes, family goals", [r for r in mazes if r[0].kind == "family goal"])
    summary("generated mazes, random goals", [r for r in mazes if r[0].kind == "random goal"])
    summary("generated mazes, all goals", mazes)
    summary("every run with a goal", [r for r in rows if r[0].kind != "symmetric"])
    errors = [r for _, r, _ in rows if r["error"]]
    if errors:
        print(f"{len(errors)} episodes raised: first: {errors[0]['error']}")


def _out() -> Path:
    out = ROOT / "out" / "bench"
    out.mkdir(parents=True, exist_ok=True)
    return out


if __name__ == "__main__":
    main()
