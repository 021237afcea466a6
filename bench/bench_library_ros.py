"""The same episode spec in the library and through ROS lockstep: the same outcome?

    .venv/bin/python bench/bench_library_ros.py                  # the sweep: library against ROS, spec by spec
    .venv/bin/python bench/bench_library_ros.py --quick          # a few specs of each controller
    .venv/bin/python bench/bench_library_ros.py --idle           # only the navigation specs with an idle stretch
    .venv/bin/python bench/bench_library_ros.py --trace navigation pillar_goal 1   # where two runs part

The sweep runs each spec (the wall follower, localization and navigation on shipped worlds and generated mazes,
several seeds) with `mode: library` in this process and `mode: ros` (the controller's stack composed in a child
process, amr_evaluation.ros_episode), and prints per spec: goal reached, time to goal (else the end), collisions,
the first localized observation, distance, in both, and whether they agree: the same goal verdict and collisions,
times within 2 %. Navigation also runs with an idle stretch (IDLE: option goal_after, no goal until then: localized,
nobody drives, the robot stands while time goes on, then the trip). Run it under
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; the episodes take their domains from AMR_EVALUATE_ROS_DOMAINS (default
120-199). One episode at a time: the figures are simulated time, not wall clock.

--trace CONTROLLER WORLD SEED runs one spec both ways with the shared classes instrumented (the simulator's step,
the particle filter's update, the navigator core's decision, the planner, the path handed over, both controllers'
commands: every call with the simulated time it was made at) and prints, kind by kind, the first call whose
inputs or outputs differ, and the step each run got its first localized estimate and its first plan at. The ROS run
is the child of ros_episode, instrumented in its process (the nodes are composed: the same classes).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from amr_evaluation import configs
from amr_evaluation.episode import EpisodeSpec, run_episode

AGREEMENT = 0.02
"""relative difference of the times within which library and ROS agree."""
DURATIONS = {"wall_follower": 60.0, "localization": 20.0, "navigation": 150.0}
SWEEP = {
    "wall_follower": (["open_room", "inner_maze", {"family": "bends", "seed": 1}], [0, 1]),
    "localization": (["inner_maze", "hard_maze", "open_room"], [0, 1]),
    "navigation": (["pillar_goal", "open_room", "hard_maze", {"family": "pillars", "seed": 2}], [0, 1, 2]),
}
QUICK = {
    "wall_follower": (["open_room", {"family": "bends", "seed": 1}], [0]),
    "localization": (["inner_maze"], [0]),
    "navigation": (["pillar_goal", "open_room"], [0, 1]),
}
IDLE = (["pillar_goal", "open_room"], [0, 1], 3.0)
"""navigation with an idle stretch: worlds, seeds, goal_after (s)."""
QUICK_IDLE = (["pillar_goal"], [1], 3.0)


def world_spec(world) -> dict:
    return world if isinstance(world, dict) else {"file": f"{world}.yaml"}


def spec_of(controller: str, world, seed: int, args, options: dict | None = None) -> EpisodeSpec:
    label, parameters = configs.resolve(controller, "sim" if controller == "wall_follower" else "default")
    goal = "far" if isinstance(world, dict) and controller == "navigation" else None
    return EpisodeSpec(
        controller,
        label,
        parameters,
        world_spec(world),
        goal,
        seed=seed,
        encoder_noise=args.encoder_noise,
        slip=args.slip,
        duration=DURATIONS[controller],
        options=options or {},
    )


def outcome(record: dict) -> str:
    if record["error"]:
        return f"error: {record['error'][:60]}"
    goal = {True: "goal", False: "no goal", None: "-"}[record["goal_reached"]]
    localized = record["time_to_localized"]
    return (
        f"{goal:7s} {record['time_to_goal'] or record['time']:7.2f} s  {record['collisions']} coll  "
        f"loc {'-' if localized is None else f'{localized:5.2f}'}  {record['distance'] or 0.0:6.2f} m"
    )


def agree(library: dict, ros: dict) -> tuple[bool, float]:
    """(same outcome, relative time difference): the goal verdict and collisions equal, the times within 2 %."""
    if library["error"] or ros["error"]:
        return False, math.nan
    a, b = library["time_to_goal"] or library["time"], ros["time_to_goal"] or ros["time"]
    difference = abs(a - b) / max(a, 1e-9)
    same = library["goal_reached"] == ros["goal_reached"] and library["collisions"] == ros["collisions"]
    return same and difference <= AGREEMENT, difference


def sweep(args) -> int:
    table = {} if args.idle else QUICK if args.quick else SWEEP
    runs = [
        (controller, world, seed, None)
        for controller in args.controllers
        for world in table.get(controller, ((), ()))[0]
        for seed in table[controller][1]
    ]
    if "navigation" in args.controllers:
        worlds, seeds, after = QUICK_IDLE if args.quick else IDLE
        runs += [("navigation", world, seed, {"goal_after": after}) for world in worlds for seed in seeds]
    rows, parted = 0, 0
    print(f"library / ROS lockstep; encoder noise {args.encoder_noise}, slip {args.slip}; simulated seconds")
    for controller, world, seed, options in runs:
        spec = spec_of(controller, world, seed, args, options)
        began = time.perf_counter()
        library = run_episode(spec)
        ros = run_episode(dataclasses.replace(spec, mode="ros"))
        same, difference = agree(library, ros)
        rows += 1
        parted += not same
        name = world if isinstance(world, str) else f"{world['family']}_{world['seed']}"
        label = controller if options is None else f"{controller} idle"
        print(
            f"{label:15s} {name:12s} seed {seed}  library {outcome(library)}  |  ROS {outcome(ros)}  |  "
            f"{difference * 100:5.2f} %  {'agree' if same else 'PART'}  ({time.perf_counter() - began:.0f} s)",
            flush=True,
        )
    print(f"{rows - parted} of {rows} specs agree (goal, collisions, time within {AGREEMENT * 100:g} %)")
    return 0 if parted == 0 else 1


# -- --trace: both runs instrumented ---------------------------------------------------------------------------

TRACE: list = []
NOW = [0.0]


def _rounded(value, digits: int = 6):
    if isinstance(value, (list, tuple)):
        return [_rounded(v, digits) for v in value]
    if isinstance(value, (bool, str)) or value is None:
        return value
    return round(float(value), digits)


def instrument() -> None:
    """Every call of the shared classes recorded in TRACE with the simulated time it was made at."""
    import numpy as np

    from amr_control.path_follower import PathFollower
    from amr_control.wall_follower import WallFollower
    from amr_localization.particle_filter import ParticleFilter
    from amr_navigation.navigator_core import NavigatorCore
    from amr_planning.planner import Planner
    from amr_simulation.fleet import Fleet

    def wrap(cls, name, record, label=None):
        original = getattr(cls, name)

        def wrapper(self, *args, **kwargs):
            result = original(self, *args, **kwargs)
            TRACE.append([label or name, NOW[0], *_rounded(record(self, result, *args, **kwargs))])
            return result

        setattr(cls, name, wrapper)

    step = Fleet.step

    def stepped(self, commands):
        TRACE.append(["step", NOW[0], _rounded([list(c) for c in commands]), _rounded(list(self.robots[0].pose))])
        step(self, commands)
        NOW[0] = round(self.time, 6)

    Fleet.step = stepped
    wrap(
        ParticleFilter,
        "update",
        lambda self, e, odometry, scan=None, *a, **k: [
            list(odometry),
            float(np.nansum(np.where(np.isfinite(scan.ranges), scan.ranges, 0.0))) if scan is not None else 0.0,
            [e.pose.x, e.pose.y, e.pose.theta],
            e.localized,
            e.status.confidence,
        ],
    )
    wrap(Planner, "plan", lambda self, path, start, goal: [list(start[:2]), list(goal[:2]), len(path), path.sum()])
    wrap(PathFollower, "set_path", lambda self, result, points, *a: [len(points), np.sum(points)])
    wrap(
        PathFollower,
        "compute",
        lambda self, c, x, y, theta, scan=None, speed_limit=None: [[x, y, theta], c.v, c.w, c.state.value],
        "path_follower",
    )
    wrap(WallFollower, "compute", lambda self, c, scan, v, w, stamp: [v, w, c.v, c.w], "wall_follower")
    core_step = NavigatorCore.step

    def decided(self, observation):
        result = yield from core_step(self, observation)
        d = result.decision
        TRACE.append(["decide", NOW[0], d.mode.value, d.controller.value, d.reason, _rounded(list(observation.pose))])
        return result

    NavigatorCore.step = decided


def trace(args) -> int:
    from amr_util.environment import child_environment

    controller, world, seed = args.trace[0], args.trace[1], int(args.trace[2])
    spec = spec_of(controller, world, seed, args)
    spec = dataclasses.replace(spec, duration=args.duration or spec.duration)
    with tempfile.TemporaryDirectory(prefix="bench_library_ros_") as scratch:
        directory = Path(scratch)
        (directory / "spec.json").write_text(json.dumps(dataclasses.replace(spec, mode="ros").to_dict()))
        env = child_environment(
            ROS_DOMAIN_ID=os.environ.get("ROS_DOMAIN_ID", "120"), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"
        )
        with (directory / "stack.log").open("w") as log:
            child = subprocess.run(
                [sys.executable, __file__, "--trace-child", str(directory)], env=env, stdout=log, stderr=log
            )
        if child.returncode != 0:
            print((directory / "stack.log").read_text()[-3000:])
            return 2
        ros = json.loads((directory / "trace.json").read_text())
    instrument()
    record = run_episode(spec)
    library = json.loads(json.dumps(TRACE))
    print(f"{controller} {world} seed {seed}: library {outcome(record)}")
    for kind in ("step", "update", "decide", "plan", "set_path", "wall_follower", "path_follower"):
        a, b = [e for e in library if e[0] == kind], [e for e in ros if e[0] == kind]
        first = next((i for i, (x, y) in enumerate(zip(a, b, strict=False)) if not _close(x, y)), None)
        if first is None:
            print(
                f"{kind:13s} {len(a)} / {len(b)} calls (library / ROS), the same over the first {min(len(a), len(b))}"
            )
        else:
            print(f"{kind:13s} first differs at call {first} (t = {a[first][1]} s)")
            print(f"  library {a[first]}\n  ROS     {b[first]}")
    for name, calls in (("library", library), ("ROS", ros)):
        localized = next((e[1] for e in calls if e[0] == "update" and e[5]), None)
        planned = next((e[1] for e in calls if e[0] == "plan"), None)
        print(f"{name}: first localized estimate at t = {localized} s, first plan at t = {planned} s")
    return 0


def _close(a, b, tolerance: float = 1e-5) -> bool:
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y, tolerance) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) <= tolerance
    return a == b


def trace_child(directory: Path) -> int:
    """The ROS run of --trace: ros_episode's child, instrumented."""
    from amr_evaluation import ros_episode

    spec = EpisodeSpec.from_dict(json.loads((directory / "spec.json").read_text()))
    ros_episode._compile_kernels(spec)  # its library run before the instruments, not in the ROS run's trace
    ros_episode._compile_kernels = lambda spec: 0.0
    instrument()
    ros_episode._episode_in_this_process(spec, directory)
    (directory / "trace.json").write_text(json.dumps(TRACE))
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a few specs of each controller")
    parser.add_argument("--idle", action="store_true", help="only the navigation specs with an idle stretch (IDLE)")
    parser.add_argument("--controllers", nargs="+", default=list(SWEEP), choices=list(SWEEP))
    parser.add_argument("--encoder-noise", type=float, default=0.0)
    parser.add_argument("--slip", type=float, default=0.0)
    parser.add_argument("--trace", nargs=3, metavar=("CONTROLLER", "WORLD", "SEED"), help="where two runs part")
    parser.add_argument("--duration", type=float, help="--trace: simulated s at most (default: the sweep's)")
    parser.add_argument("--trace-child", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.trace_child is not None:
        return trace_child(args.trace_child)
    if args.trace:
        return trace(args)
    return sweep(args)


if __name__ == "__main__":
    raise SystemExit(main())
