"""Several robots navigating in generated worlds at library level (issue 22's fleet figure).

    .venv/bin/python bench/bench_fleet_navigation.py                      # the default grid (see --help)
    .venv/bin/python bench/bench_fleet_navigation.py --robots 2 3 --families perfect pillars --seeds 2

Worlds: generated mazes (`perfect`, `loops`) and rooms with pillars (`pillars`) of amr_maps.maze_families
(--size m a side), their own start and goal dropped. N robots start on free cells spread over the world
(farthest-point sampling on the planner's costmap, at least MIN_SEPARATION apart, random headings), and each
is sent to the next one's start (robot i to robot i+1's, the last to the first's): every path runs against
another robot's, and in a maze face to face in corridors one robot wide. Per robot: the whole loop (explore
with the wall follower until its particle filter says localized, plan, follow) with the traffic rules
(amr_navigation.traffic), the robots' posts on one board; amr_evaluation.fleet_navigation.run_fleet in
lockstep on the simulator's Fleet (LiDAR noise 0.01 m, no encoder noise, seeded per run).

Prints one line per run (robots at their goal, robot-robot and wall contacts, robots ever falsely localized
(localized with the estimate more than 0.3 m off), yields, stops, replans around, simulated and wall-clock
time; with the filter: times localized was withdrawn after a declaration, s the robots spent unsure after their
first declaration (summed; while unsure a robot posts no position on the traffic board), and the span of the
robots' first declarations) and the totals. --jobs N runs N worlds at once (at most 2 on the shared 2-core machine).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from amr_maps.maze_families import generate  # noqa: E402
from amr_evaluation.fleet_navigation import with_robots  # noqa: E402
from amr_maps.world import world_from_dict  # noqa: E402

def fleet_world(family: str, seed: int, robots: int, size: float) -> dict:
    """A generated world with `robots` robots, each sent to the next one's start."""
    data = with_robots(generate(family, seed, size=size), robots, seed)
    data["name"] = f"{family}_{seed}_{robots}robots"
    return data


def one(args: tuple) -> dict:
    family, seed, robots, size, duration, localization = args
    from amr_evaluation.fleet_navigation import run_fleet

    data = fleet_world(family, seed, robots, size)
    run = run_fleet(world_from_dict(data), seed=seed, duration=duration, localization=localization)
    result = run.as_dict()
    result.update(family=family, seed=seed, size=size, localization=localization,
                  yields=sum(r.yields for r in run.robots), stops=sum(r.stops for r in run.robots),
                  replans_around=sum(r.replans_around for r in run.robots),
                  unreached=[r.name for r in run.robots if not r.reached])
    return result


def _first_localized(result: dict) -> str:
    """The robots' first declarations of localized, earliest-latest s (and how many never), '-' with truth."""
    if result["localization"] == "truth":
        return "-"
    times = [r["first_localized"] for r in result["per_robot"] if r["first_localized"] is not None]
    never = len(result["per_robot"]) - len(times)
    span = f"{min(times):.1f}-{max(times):.1f}" if times else "none"
    return span + (f" ({never} never)" if never else "")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--families", nargs="+", default=["perfect", "loops", "pillars"])
    parser.add_argument("--robots", nargs="+", type=int, default=[2, 4, 6])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--size", type=float, default=4.0, help="m, side of the generated world")
    parser.add_argument("--duration", type=float, default=300.0, help="s simulated at most per run")
    parser.add_argument("--localization", choices=("filter", "truth"), default="filter")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    cases = [(family, seed, robots, args.size, args.duration, args.localization) for family in args.families
             for robots in args.robots for seed in range(args.first_seed, args.first_seed + args.seeds)]
    print(f"{len(cases)} runs: families {', '.join(args.families)}, {args.size:g} m, robots {args.robots}, "
          f"{args.seeds} seeds, localization {args.localization}, limit {args.duration:g} s simulated, "
          f"{args.jobs} processes, load {os.getloadavg()[0]:.1f}")
    print("world                      robots  at goal  robot-robot  wall  false loc.  yields  stops  around  "
          "sim s  wall s  withdrawn  unsure s  first loc. s")
    began = time.perf_counter()
    results = []
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for result in pool.map(one, cases):
            results.append(result)
            name = f"{result['family']} {result['seed']}"
            print(f"{name:26s} {result['robots']:6d} {result['reached']:8d} {result['robot_contacts']:12d} "
                  f"{result['wall_contacts']:5d} {result['false_localized']:11d} {result['yields']:7d} "
                  f"{result['stops']:6d} {result['replans_around']:7d} {result['time']:6.1f} "
                  f"{result['wall_time']:7.1f} {result['withdrawals']:10d} {result['unsure_time']:9.1f}  "
                  f"{_first_localized(result)}" + (f"  not at goal: {', '.join(result['unreached'])}"
                                                   if result['unreached'] else ""), flush=True)
    robots = sum(r["robots"] for r in results)
    print(f"\ntotal: {sum(r['reached'] for r in results)}/{robots} robots at their goal; "
          f"{sum(r['reached'] == r['robots'] for r in results)}/{len(results)} runs with every robot there; "
          f"robot-robot contacts {sum(r['robot_contacts'] for r in results)}, wall contacts "
          f"{sum(r['wall_contacts'] for r in results)}, robots falsely localized "
          f"{sum(r['false_localized'] for r in results)}, localized withdrawn {sum(r['withdrawals'] for r in results)} "
          f"times, {sum(r['unsure_time'] for r in results):.1f} robot-s unsure after a first declaration (longest "
          f"{max((p['longest_unsure'] for r in results for p in r['per_robot']), default=0.0):.1f} s); {time.perf_counter() - began:.0f} s wall clock, "
          f"load {os.getloadavg()[0]:.1f}")
    for family in args.families:
        rows = [r for r in results if r["family"] == family]
        print(f"  {family}: {sum(r['reached'] for r in rows)}/{sum(r['robots'] for r in rows)} at goal, "
              f"robot-robot {sum(r['robot_contacts'] for r in rows)}, wall {sum(r['wall_contacts'] for r in rows)}, "
              f"false localized {sum(r['false_localized'] for r in rows)}, median time "
              f"{np.median([r['time'] for r in rows]):.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
