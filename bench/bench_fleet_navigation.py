"""Several robots navigating in generated worlds at library level (docs/fleet.md's figures).

    .venv/bin/python bench/bench_fleet_navigation.py                      # the default grid (see --help)
    .venv/bin/python bench/bench_fleet_navigation.py --robots 2 3 --families perfect pillars --seeds 2

Worlds: generated mazes (`perfect`, `loops`) and rooms with pillars (`pillars`) of amr_maps.maze_families
(--size m a side; other families of it by name), their own start and goal dropped. N robots start on free cells
spread over the world (farthest-point sampling on the planner's costmap, at least MIN_SEPARATION apart, random
headings, all in the largest region a robot can drive through: `dead_ends` mazes have walled cells), and each
is sent to the next one's start (robot i to robot i+1's, the last to the first's): every path runs against
another robot's, and in a maze face to face in corridors one robot wide. Per robot: the whole loop (explore
with the wall follower until its particle filter says localized, plan, follow) with the traffic rules
(amr_navigation.traffic), the robots' posts on one board; amr_evaluation.fleet_navigation.run_fleet in
lockstep on the simulator's Fleet (LiDAR noise 0.01 m, no encoder noise, seeded per run).

Prints one line per run (robots at their goal, robot-robot and wall contacts, robots ever falsely localized
(localized with the estimate more than 0.3 m off), yields, stops, replans around, simulated and wall-clock
time; with the filter: times localized was withdrawn after a declaration, s the robots spent unsure after their
first declaration (summed; while unsure a robot posts no position on the traffic board), and the span of the
robots' first declarations) and the totals. A world too small for N robots MIN_SEPARATION apart is named and left
out. In a single corridor (`bends`, `curved`, `narrowing`) robots cannot pass each other, so sending each to the
next one's start has no solution there: those families are no test of the fleet (docs/fleet.md). --jobs N runs N
worlds at once (at most 2 on the shared 2-core machine).

--ros runs the same worlds through ROS instead: the world written to a YAML file, `amr-bringup fleet_navigation
world:=<file> --composed` started as a process of its own (every node of every robot in one process, the
particle filters included; the stack's own configuration, config/*.yaml), and each robot's `/<name>/status`
read until every robot is at its goal or --duration simulated seconds have passed (with --coordination plan the
stack runs `coordination:=plan` and its fleet_planner node, with the lattice spacing of the library level; robots
at goal, contacts, falsely localized (each spell printed: robot, from-to s, the largest error), withdrawals and
time unsure from those statuses; yields, stops and replans are not on a topic: '-'). --keep DIR keeps each run's
world YAML and amr-bringup log in DIR. One world at a time (--jobs is ignored); run it under
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a ROS_DOMAIN_ID of its own (the child inherits both).
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from amr_evaluation.fleet_navigation import lattice_spacing  # noqa: E402
from amr_maps.maze_families import generate  # noqa: E402
from amr_maps.world import world_from_dict  # noqa: E402
from amr_planning.fleet_starts import with_robots  # noqa: E402


def fleet_world(family: str, seed: int, robots: int, size: float) -> dict:
    """A generated world with `robots` robots, each sent to the next one's start."""
    data = with_robots(generate(family, seed, size=size), robots, seed)
    data["name"] = f"{family}_{seed}_{robots}robots"
    return data


def one(args: tuple) -> dict:
    family, seed, robots, size, duration, localization, coordination = args
    from amr_evaluation.fleet_navigation import run_fleet

    data = fleet_world(family, seed, robots, size)
    run = run_fleet(
        world_from_dict(data),
        seed=seed,
        duration=duration,
        localization=localization,
        coordination=coordination,
        lattice_spacing=lattice_spacing(data, family),
    )
    result = run.as_dict()
    result.update(
        family=family,
        seed=seed,
        size=size,
        localization=localization,
        yields=sum(r.yields for r in run.robots),
        stops=sum(r.stops for r in run.robots),
        replans_around=sum(r.replans_around for r in run.robots),
        unreached=[r.name for r in run.robots if not r.reached],
    )
    return result


def through_ros(args: tuple, keep: Path | None = None) -> dict:
    """One world through ROS: `amr-bringup fleet_navigation --composed` in a process of its own, watched on the
    robots' status topics (the world and the stack's log kept in `keep` if given)."""
    import rclpy
    import yaml
    from rclpy.executors import SingleThreadedExecutor

    from amr_evaluation.fleet_navigation import FALSE_LOCALIZED_ERROR, FleetRun, RobotRun
    from amr_evaluation.ros_episode import stop_process
    from amr_interfaces.msg import SimulatorStatus
    from amr_util.environment import child_environment

    family, seed, robots, size, duration, _, coordination = args
    data = fleet_world(family, seed, robots, size)
    planned = [f"coordination:={coordination}"] + (
        [f"lattice_spacing:={lattice_spacing(data, family)}"] if coordination == "plan" else []
    )
    names = [robot["name"] for robot in data["robots"]]
    last: dict = {}
    runs = {name: RobotRun(name) for name in names}  # counted as the library level's run_fleet does
    spells: dict = {name: [] for name in names}
    """per robot: [begin, end, largest error] of each time it was falsely localized (end None: to the last)."""

    def watch(name):
        def on_status(message) -> None:
            before = last.get(name)
            last[name] = message
            run = runs[name]
            run.note_localized(
                message.sim_time,
                message.localized,
                max(0.0, message.sim_time - before.sim_time) if before is not None else 0.0,
            )
            false = bool(message.localized and message.position_error > FALSE_LOCALIZED_ERROR)
            run.false_localized_steps += int(false)
            spell = spells[name][-1] if spells[name] and spells[name][-1][1] is None else None
            if false and spell is None:
                spells[name].append([message.sim_time, None, message.position_error])
            elif false:
                spell[2] = max(spell[2], message.position_error)
            elif spell is not None:
                spell[1] = message.sim_time
            run.reached, run.wall_collisions, run.robot_collisions = (
                message.goal_reached,
                message.wall_collisions,
                message.robot_collisions,
            )

        return on_status

    began = time.perf_counter()
    reason, errors = "time limit", ""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{data['name']}.yaml"
        path.write_text(yaml.safe_dump(data, sort_keys=False))
        context = rclpy.Context()
        rclpy.init(context=context)
        node = rclpy.create_node("bench_fleet_observer", context=context)
        for name in names:
            node.create_subscription(SimulatorStatus, f"/{name}/status", watch(name), 10)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        log = open(Path(folder) / "bringup.log", "w+")
        process = subprocess.Popen(
            [sys.executable, "-m", "amr_bringup.bringup", "fleet_navigation", f"world:={path}", *planned, "--composed"],
            env=child_environment(),
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        try:
            while True:
                executor.spin_once(timeout_sec=0.2)
                if process.poll() is not None:
                    reason = f"amr-bringup exited with {process.returncode}"
                    break
                if len(last) == len(names) and all(last[name].goal_reached for name in names):
                    reason = "every robot at its goal"
                    break
                if len(last) == len(names) and min(message.sim_time for message in last.values()) >= duration:
                    break
                if len(last) < len(names) and time.perf_counter() - began > 300.0:
                    reason = "not every robot's status within 300 s"
                    break
        finally:
            stop_process(process, timeout=60.0)
            log.seek(0)
            errors = log.read()
            log.close()
            if keep is not None:  # the world and the stack's log, to trace a run
                keep.mkdir(parents=True, exist_ok=True)
                (keep / path.name).write_text(path.read_text())
                (keep / f"{data['name']}.log").write_text(errors)
            executor.shutdown()
            node.destroy_node()
            context.try_shutdown()
    if reason != "every robot at its goal" and reason != "time limit":
        print(f"{data['name']}: {reason}\n{errors[-3000:]}", file=sys.stderr)
    result = FleetRun(
        list(runs.values()),
        max((m.sim_time for m in last.values()), default=math.nan),
        time.perf_counter() - began,
        reason,
    ).as_dict()
    result.update(
        family=family,
        seed=seed,
        size=size,
        localization="filter (ROS)",
        yields="-",
        stops="-",
        replans_around="-",
        unreached=[name for name in names if not runs[name].reached],
        false_spells=[
            f"{name} {begin:.1f}-{'end' if end is None else f'{end:.1f}'} s ({largest:.2f} m off)"
            for name in names
            for begin, end, largest in spells[name]
        ],
    )
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
    parser.add_argument(
        "--coordination",
        choices=("rules", "plan"),
        default="rules",
        help="rules: each robot's traffic rules; plan: the fleet planned together once every robot is localized",
    )
    parser.add_argument(
        "--ros",
        action="store_true",
        help="through ROS: amr-bringup fleet_navigation --composed per world, one at a time",
    )
    parser.add_argument(
        "--keep", type=Path, metavar="DIR", help="with --ros: keep each run's world YAML and amr-bringup log in DIR"
    )
    args = parser.parse_args(argv)
    if args.ros:
        args.jobs, args.localization = 1, "filter"
    cases = [
        (family, seed, robots, args.size, args.duration, args.localization, args.coordination)
        for family in args.families
        for robots in args.robots
        for seed in range(args.first_seed, args.first_seed + args.seeds)
    ]
    fitting = []
    for case in cases:  # a world too small for the robots (a short corridor) is named and left out
        try:
            fleet_world(*case[:4])
            fitting.append(case)
        except ValueError as error:
            print(f"left out: {error}")
    cases = fitting
    print(
        f"{len(cases)} runs: families {', '.join(args.families)}, {args.size:g} m, robots {args.robots}, "
        f"{args.seeds} seeds, localization {args.localization}{' through ROS' if args.ros else ''}, "
        f"coordination {args.coordination}, "
        f"limit {args.duration:g} s simulated, "
        f"{args.jobs} processes, load {os.getloadavg()[0]:.1f}"
    )
    print(
        "world                      robots  at goal  robot-robot  wall  false loc.  yields  stops  around  "
        "sim s  wall s  withdrawn  unsure s  first loc. s"
    )
    began = time.perf_counter()
    results = []
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for result in (through_ros(case, args.keep) for case in cases) if args.ros else pool.map(one, cases):
            results.append(result)
            name = f"{result['family']} {result['seed']}"
            print(
                f"{name:26s} {result['robots']:6d} {result['reached']:8d} {result['robot_contacts']:12d} "
                f"{result['wall_contacts']:5d} {result['false_localized']:11d} {result['yields']:>7} "
                f"{result['stops']:>6} {result['replans_around']:>7} {result['time']:6.1f} "
                f"{result['wall_time']:7.1f} {result['withdrawals']:10d} {result['unsure_time']:9.1f}  "
                f"{_first_localized(result)}"
                + (f"  not at goal: {', '.join(result['unreached'])}" if result["unreached"] else "")
                + (f"  falsely localized: {'; '.join(result['false_spells'])}" if result.get("false_spells") else ""),
                flush=True,
            )
    robots = sum(r["robots"] for r in results)
    longest = max((p["longest_unsure"] for r in results for p in r["per_robot"]), default=0.0)
    print(
        f"\ntotal: {sum(r['reached'] for r in results)}/{robots} robots at their goal; "
        f"{sum(r['reached'] == r['robots'] for r in results)}/{len(results)} runs with every robot there; "
        f"robot-robot contacts {sum(r['robot_contacts'] for r in results)}, wall contacts "
        f"{sum(r['wall_contacts'] for r in results)}, robots falsely localized "
        f"{sum(r['false_localized'] for r in results)}, localized withdrawn {sum(r['withdrawals'] for r in results)} "
        f"times, {sum(r['unsure_time'] for r in results):.1f} robot-s unsure after a first declaration (longest "
        f"{longest:.1f} s); {time.perf_counter() - began:.0f} s wall clock, "
        f"load {os.getloadavg()[0]:.1f}"
    )
    for family in args.families:
        rows = [r for r in results if r["family"] == family]
        print(
            f"  {family}: {sum(r['reached'] for r in rows)}/{sum(r['robots'] for r in rows)} at goal, "
            f"robot-robot {sum(r['robot_contacts'] for r in rows)}, wall {sum(r['wall_contacts'] for r in rows)}, "
            f"false localized {sum(r['false_localized'] for r in rows)}, median time "
            f"{np.median([r['time'] for r in rows]):.1f} s"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
