"""When the fleet is planned, and from what: the fleet coordinator's plans at library level.

    .venv/bin/python bench/bench_fleet_confidence.py --families perfect --robots 6 --seeds 4

The worlds and the run of bench/bench_fleet_navigation.py with `--coordination plan` and the particle filters
(amr_evaluation.fleet_navigation.run_fleet, one process). Per run it prints what that bench prints (robots at
goal, contacts, robots ever falsely localized, sim s) and what the fleet coordinator did: when the first plan was
made, how many plans (whole and partial), the replans for a jumped pose and for a stuck robot, and the plans made
from an estimate off the truth: for every plan begun, the largest distance between a robot's status position (the
pose its navigator drives by) and its true position; a plan with one more than FALSE_LOCALIZED_ERROR (0.3 m) off
sends that robot the wrong way. The parameters are the shipped ones of the tree the script is in (its config/), so
that a copy of an older commit runs with its own. It asserts nothing.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import amr_evaluation.configs as configs  # noqa: E402
import amr_evaluation.fleet_navigation as fleet_navigation  # noqa: E402
from amr_evaluation.fleet_navigation import FALSE_LOCALIZED_ERROR, lattice_spacing, run_fleet  # noqa: E402
from amr_maps.world import world_from_dict  # noqa: E402
from amr_navigation.fleet_coordinator import FleetCoordinator  # noqa: E402
from amr_navigation.navigator_core import NavigatorCore  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fleet_navigation import fleet_world  # noqa: E402


def one(family: str, seed: int, robots: int, size: float, duration: float, settle_time: float | None = None) -> dict:
    """One run, the coordinator's plans watched: each plan begun, the worst status error against the truth."""
    fleets: list = []
    plans: list = []  # (time, worst error m, partial)

    class WatchedFleet(fleet_navigation.Fleet):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            fleets.append(self)

    begin_plan, init = FleetCoordinator.begin_plan, FleetCoordinator.__init__

    def settled_init(coordinator, *args, **kwargs):
        init(coordinator, *args, **kwargs, settle_time=settle_time)

    def watched_begin_plan(coordinator):
        job, holds = begin_plan(coordinator)
        fleet = fleets[-1]
        errors = [
            math.hypot(status.x - fleet.robot(name).pose.x, status.y - fleet.robot(name).pose.y)
            for name, status in zip(coordinator.names, job.statuses, strict=True)
        ]
        plans.append((fleet.time, max(errors), bool(job.replan)))
        return job, holds

    on_route = NavigatorCore._on_route
    steps = {"route": 0, "unsure": 0, "unlocalized": 0}

    def watched_on_route(core, observation, driving, events):
        steps["route"] += 1
        steps["unsure"] += not core.gate.sure  # driven by odometry from the last sure estimate (DeadReckoning)
        steps["unlocalized"] += not observation.localized  # the filter's own flag
        return (yield from on_route(core, observation, driving, events))

    data = fleet_world(family, seed, robots, size)
    configs.share_directory = lambda package: ROOT  # this tree's config/, not the working tree's installed share
    fleet_navigation.Fleet, FleetCoordinator.begin_plan = WatchedFleet, watched_begin_plan
    NavigatorCore._on_route = watched_on_route
    if settle_time is not None:  # a coordinator with the settle_time guard it had before the confidence
        FleetCoordinator.__init__ = settled_init
    try:
        run = run_fleet(
            world_from_dict(data),
            seed=seed,
            duration=duration,
            localization="filter",
            coordination="plan",
            lattice_spacing=lattice_spacing(data, family),
        )
    finally:
        fleet_navigation.Fleet, FleetCoordinator.begin_plan = WatchedFleet.__base__, begin_plan
        FleetCoordinator.__init__, NavigatorCore._on_route = init, on_route
    events = [event for robot in run.robots for event in robot.events]
    return {
        "run": run.as_dict(),
        "plans": plans,
        "jumped": sum("pose jumped" in event for event in events),
        "stuck": sum("has not reached its next waypoint" in event for event in events),
        "steps": steps,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--families", nargs="+", default=["perfect"])
    parser.add_argument("--robots", nargs="+", type=int, default=[6])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--size", type=float, default=4.0, help="m, side of the generated world")
    parser.add_argument("--duration", type=float, default=300.0, help="s simulated at most per run")
    parser.add_argument(
        "--settle-time", type=float, help="s: a coordinator with the settle_time guard of before the confidence"
    )
    args = parser.parse_args(argv)
    print(
        f"families {', '.join(args.families)}, {args.size:g} m, robots {args.robots}, seeds {args.first_seed}-"
        f"{args.first_seed + args.seeds - 1}, particle filters, coordination plan, limit {args.duration:g} s, "
        + (f"settle_time {args.settle_time:g} s, " if args.settle_time is not None else "")
        + f"load {os.getloadavg()[0]:.1f}"
    )
    print(
        "world          robots  at goal  contacts  false loc.   sim s  first plan s  plans  partial  jumped  stuck  "
        "route steps unsure/unloc.  off"
    )
    totals = {"robots": 0, "reached": 0, "complete": 0, "runs": 0, "false": 0, "off": 0, "plans": 0, "jumped": 0}
    route_steps = {"route": 0, "unsure": 0, "unlocalized": 0}
    began = time.perf_counter()
    for family in args.families:
        for robots in args.robots:
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                try:
                    result = one(family, seed, robots, args.size, args.duration, args.settle_time)
                except ValueError as error:  # a world too small for the robots
                    print(f"left out: {error}")
                    continue
                run, plans, steps = result["run"], result["plans"], result["steps"]
                off = [f"{t:.1f} s: {error:.2f} m" for t, error, _ in plans if error > FALSE_LOCALIZED_ERROR]
                first = f"{plans[0][0]:.1f}" if plans else "-"
                print(
                    f"{family + ' ' + str(seed):14s} {run['robots']:6d} {run['reached']:8d} "
                    f"{run['robot_contacts'] + run['wall_contacts']:9d} {run['false_localized']:11d} "
                    f"{run['time']:7.1f} {first:>13} {len(plans):6d} {sum(p[2] for p in plans):8d} "
                    f"{result['jumped']:7d} {result['stuck']:6d}  {steps['route']:11d} "
                    f"{steps['unsure']:6d}/{steps['unlocalized']:<6d}"
                    f"  {len(off)}" + (f" ({'; '.join(off)})" if off else ""),
                    flush=True,
                )
                totals["runs"] += 1
                totals["robots"] += run["robots"]
                totals["reached"] += run["reached"]
                totals["complete"] += run["reached"] == run["robots"]
                totals["false"] += run["false_localized"]
                totals["off"] += len(off)
                totals["plans"] += len(plans)
                totals["jumped"] += result["jumped"]
                for key, value in steps.items():
                    route_steps[key] += value
    print(
        f"\ntotal: {totals['reached']}/{totals['robots']} robots at their goal, {totals['complete']}/{totals['runs']} "
        f"runs complete; robots falsely localized {totals['false']}; {totals['plans']} plans, {totals['off']} of them "
        f"from a status more than {FALSE_LOCALIZED_ERROR} m off the truth; {totals['jumped']} jump replans; "
        f"{route_steps['route']} robot-steps on a route, {route_steps['unsure']} of them unsure (driven by odometry "
        f"from the last sure estimate; the filter said not localized at {route_steps['unlocalized']}); "
        f"{time.perf_counter() - began:.0f} s wall clock"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
