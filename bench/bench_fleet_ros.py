"""How fast the fleet_navigation stack runs through ROS, and where its CPU goes.

    .venv/bin/python bench/bench_fleet_ros.py --robots 5 10 20            # real-time factor and CPU per robot-step
    .venv/bin/python bench/bench_fleet_ros.py --robots 5 --profile        # and where the CPU goes, thread by thread
    .venv/bin/python bench/bench_fleet_ros.py --robots 5 --cprofile       # by function, each thread's own CPU time

Each run: a generated world (`--family`, default `pillars` rooms, `--size` m a side, default 4 m up to 6 robots
and larger for more: SIZE_PER_ROBOT) with N robots each sent to the next one's start (bench_fleet_navigation's
worlds), and `amr-bringup fleet_navigation world:=<file> --composed` (every node of every robot in one process,
particle filters included, `coordination:=plan` with its fleet_planner) started as a child process. This process
reads `/clock`; `--warmup` s of wall clock after /clock passed `--from-sim` (20 s: the robots' filters have localized
them, the global place search is over) it measures `--measure` s: the real-time factor
(simulated s over wall s, from /clock) and the child's CPU time (/proc/<pid>/stat: every thread) per robot-step (a
step is the simulator's dt, 0.05 s, for one robot).

--profile samples the child's threads (a sampler thread in it, py-spy style, at `--hz`): each thread's own CPU
clock (time.pthread_getcpuclockid) gives the CPU by node kind (each composed node spins on a thread named
`spin <node>`: simulator, particle_filter, navigator, ...); the stack of every thread not blocked at the sample
(`_idle`: not in a wait, a sleep, a lock) gives the split by layer (the executor, publishing, our packages) and the
functions that cost most (self and inclusive). With dozens of threads taking turns on the GIL, a thread waiting for
the GIL is sampled where it waits: the split is a hint; `perf record -p <child pid>` splits by library. It also
counts every callback by node and topic (or timer) and every wait (the lean executor waits once a spin_once;
rclpy's may wait several times, rebuilding its wait set: `_wait_for_ready_callbacks`). `--executor stock` runs the
nodes on rclpy's SingleThreadedExecutor instead of amr_util.lean_executor (an A/B). Run it under
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a ROS_DOMAIN_ID of its own (the child inherits both). One run at a
time: the machine has 2 cores.

--cprofile profiles every spinning thread with cProfile on its own CPU clock (time.thread_time: a thread waiting for
the GIL or a wake-up costs nothing) over the measured window, merged: the functions by own CPU and, of ours,
inclusive. Deterministic but slow (it about doubles the CPU): its run's real-time figures are not the stack's.
"""

from __future__ import annotations

import argparse
import json
import linecache
import os
import subprocess
import sys
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

DT = 0.05
"""s simulated per step (config/simulator.yaml)."""
SIZE_PER_ROBOT = 0.9
"""m of world side per robot beyond 6 (a 4 m world holds 6 robots 0.7 m apart with room to pass)."""


# -- the child: amr-bringup with a sampler thread ----------------------------------------------------------------


def _where(frame) -> list[str]:
    stack = []
    while frame is not None:
        code = frame.f_code
        stack.append(f"{_short(code.co_filename)}:{code.co_name}")
        frame = frame.f_back
    return stack


def _short(filename: str) -> str:
    parts = Path(filename).parts
    for anchor in ("site-packages", "main", "work"):
        if anchor in parts:
            index = len(parts) - 1 - parts[::-1].index(anchor)
            return "/".join(parts[index + 1 :])
    return "/".join(parts[-2:])


def _idle(frame) -> bool:
    """Whether a thread is blocked (in an executor's wait, a sleep, a lock): its current line waits."""
    line = linecache.getline(frame.f_code.co_filename, frame.f_lineno or 0)
    return any(word in line for word in IDLE_CALLS)


IDLE_CALLS = (".wait(", "sleep(", ".acquire(", ".join(", "select(", ".get(")
"""Calls that block: a sample of a thread whose current line is one of them finds it idle."""


def sample(out: Path, start: float, duration: float, hz: float) -> None:
    """Once the file `out`.go exists (the parent's measuring began; at most `start` s), for `duration` s: every
    thread's CPU (its own CPU clock, exact) and, every 1/hz s, the stack of each thread that is not blocked (in
    an executor's wait, a sleep: `_idle`), each such sample one 1/hz s of that thread's time (a thread mostly
    blocked spends its CPU in short callbacks between samples; charging a thread's CPU to wherever it is at the
    sample would charge it to the wait). Written to `out` as JSON (per thread name: cpu; per function: self and
    inclusive busy samples in s; executor wake-ups per thread name)."""
    wakes, entities = _count_wakes()
    go, began = out.with_suffix(".go"), time.monotonic()
    while not go.exists() and time.monotonic() - began < start:
        time.sleep(0.1)
    wakes.clear()
    callbacks_before = dict(CALLBACKS)
    own = threading.get_ident()
    clocks: dict[int, float] = {}
    by_thread: dict[str, float] = defaultdict(float)
    self_cpu: dict[str, float] = defaultdict(float)
    inclusive: dict[str, float] = defaultdict(float)
    by_thread_function: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    end = time.monotonic() + duration
    process_began = time.process_time()
    weight = 1.0 / hz
    while time.monotonic() < end:
        time.sleep(weight)
        names = {thread.ident: thread.name for thread in threading.enumerate()}
        for ident, frame in sys._current_frames().items():
            if ident == own:
                continue
            try:
                cpu = time.clock_gettime(time.pthread_getcpuclockid(ident))
            except (OSError, ProcessLookupError):
                continue
            spent, clocks[ident] = cpu - clocks.get(ident, cpu), cpu
            name = names.get(ident, str(ident))
            by_thread[name] += spent
            if _idle(frame):
                continue
            stack = _where(frame)
            self_cpu[stack[0]] += weight
            for function in set(stack):
                inclusive[function] += weight
            by_thread_function[name][stack[0]] += weight
    partial = out.with_suffix(".part")  # renamed when whole: the parent polls for `out`
    partial.write_text(
        json.dumps(
            {
                "process_cpu": time.process_time() - process_began,
                "duration": duration,
                "threads": by_thread,
                "self": self_cpu,
                "inclusive": inclusive,
                "thread_self": by_thread_function,
                "wakes": dict(wakes),
                "callbacks": {key: n - callbacks_before.get(key, 0) for key, n in CALLBACKS.items()},
                "entities": entities,
            }
        )
    )
    partial.replace(out)


def _count_wakes() -> tuple[dict[str, int], dict[str, dict[str, int]]]:
    """Count each spinning thread's executor wake-ups (spin_once) and waits from now on, and note each node's
    entities (what every wake-up's wait set is built of). rclpy's executor may wait several times per spin_once
    (`_wait_for_ready_callbacks`, rebuilding the wait set each time); the lean executor waits once."""
    from rclpy.executors import Executor, SingleThreadedExecutor

    from amr_util.lean_executor import LeanExecutor

    wakes: dict[str, int] = defaultdict(int)
    entities: dict[str, dict[str, int]] = {}

    def counting(spin_once, waits: bool):
        def counted(self, *args, **kwargs):
            thread = threading.current_thread().name
            wakes[thread] += 1
            if waits:
                wakes["waits " + thread] += 1
            if wakes[thread] % 500 == 1:  # the node's entities now (they grow on configure)
                nodes = self.get_nodes()
                entities[thread] = {
                    kind: sum(sum(1 for _ in getattr(node, kind)) for node in nodes)
                    for kind in ("subscriptions", "publishers", "services", "clients", "timers", "waitables")
                }
            return spin_once(self, *args, **kwargs)

        return counted

    SingleThreadedExecutor._spin_once_impl = counting(SingleThreadedExecutor._spin_once_impl, False)
    LeanExecutor._spin_once_impl = counting(LeanExecutor._spin_once_impl, True)
    generator = Executor._wait_for_ready_callbacks

    def waited(self, *args, **kwargs):  # one wait set built and waited on (then its ready callbacks yielded)
        wakes["waits " + threading.current_thread().name] += 1
        return generator(self, *args, **kwargs)

    Executor._wait_for_ready_callbacks = waited
    return wakes, entities


CALLBACKS: dict[str, int] = defaultdict(int)
"""Callbacks run per `<node name>: <what>` (a subscription's topic, a timer's period), counted from node creation."""


def _count_callbacks() -> None:
    """Wrap every subscription's and timer's callback created from now on with a counter (CALLBACKS): which callback
    runs how often, whichever executor runs it."""
    from rclpy.node import Node

    create_subscription, create_timer = Node.create_subscription, Node.create_timer

    def counted(key: str, callback):
        def run(*args):
            CALLBACKS[key] += 1
            return callback(*args)

        return run

    def subscription(self, msg_type, topic, callback, *args, **kwargs):
        run = counted(f"{self.get_name()}: {topic}", callback)
        return create_subscription(self, msg_type, topic, lambda message: run(message), *args, **kwargs)

    def timer(self, period, callback, *args, **kwargs):
        return create_timer(self, period, counted(f"{self.get_name()}: timer {period:g} s", callback), *args, **kwargs)

    Node.create_subscription, Node.create_timer = subscription, timer


def profile_functions(out: Path, start: float, duration: float) -> None:
    """Once `out`.go exists (at most `start` s), for `duration` s: each spinning thread profiled by cProfile on its
    own CPU clock, enabled and disabled by the thread itself at its next spin_once; the merged figures to `out` (a
    thread of its own waits and writes them; the executors are patched here, in the caller's thread: two threads
    importing rclpy at once deadlock on its modules)."""
    import cProfile
    import pstats

    from rclpy.executors import SingleThreadedExecutor

    from amr_util.lean_executor import LeanExecutor

    profilers: dict[int, cProfile.Profile] = {}
    state = {"on": False, "over": False}

    def profiled(spin_once):
        def run(self, *args, **kwargs):
            ident = threading.get_ident()
            if state["on"] and ident not in profilers:
                profilers[ident] = cProfile.Profile(time.thread_time)
                profilers[ident].enable()
            elif state["over"] and ident in profilers:
                profilers[ident].disable()
            return spin_once(self, *args, **kwargs)

        return run

    for executor in (LeanExecutor, SingleThreadedExecutor):
        executor._spin_once_impl = profiled(executor._spin_once_impl)

    def collect() -> None:
        go, began = out.with_suffix(".go"), time.monotonic()
        while not go.exists() and time.monotonic() - began < start:
            time.sleep(0.1)
        state["on"] = True
        time.sleep(duration)
        state["on"], state["over"] = False, True
        time.sleep(3.0)  # every thread spins again and stops its profiler
        merged = None
        for profiler in list(profilers.values()):
            profiler.disable()
            merged = pstats.Stats(profiler) if merged is None else merged.add(profiler)
        rows = []
        for (filename, line, name), (_, calls, own, inclusive, _) in (merged.stats if merged else {}).items():
            rows.append((f"{_short(filename)}:{name}" if line else name, calls, own, inclusive))
        partial = out.with_suffix(".part")
        partial.write_text(json.dumps({"duration": duration, "threads": len(profilers), "functions": rows}))
        partial.replace(out)

    threading.Thread(target=collect, daemon=True, name="profiler").start()


def child(argv: list[str]) -> int:
    """`--child OUT START DURATION HZ EXECUTOR PROFILER -- <amr-bringup args>`: amr-bringup here, profiled (OUT '-'
    = not profiled; PROFILER `sample` or `cprofile`), its nodes spun by EXECUTOR (`lean`: amr_util.lean_executor,
    as shipped; `stock`: rclpy's SingleThreadedExecutor, for an A/B)."""
    out, start, duration, hz, executor, profiler = argv[:6]
    if executor == "stock":
        from rclpy.executors import SingleThreadedExecutor

        import amr_util.executors

        amr_util.executors.LeanExecutor = SingleThreadedExecutor
    if out != "-" and profiler == "cprofile":
        profile_functions(Path(out), float(start), float(duration))
    elif out != "-":
        _count_callbacks()
        threading.Thread(
            target=sample, args=(Path(out), float(start), float(duration), float(hz)), daemon=True, name="sampler"
        ).start()
    from amr_bringup.bringup import main

    return main(argv[7:])


# -- the parent --------------------------------------------------------------------------------------------------


def world_for(robots: int, family: str, size: float | None, seed: int) -> dict:
    from bench_fleet_navigation import fleet_world

    side = size if size is not None else max(4.0, 4.0 + SIZE_PER_ROBOT * (robots - 6))
    return fleet_world(family, seed, robots, side)


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run(robots: int, args) -> dict:
    """One stack of `robots` robots: the real-time factor and CPU per robot-step over the measured window."""
    import rclpy
    import yaml
    from rclpy.executors import SingleThreadedExecutor
    from rosgraph_msgs.msg import Clock

    from amr_evaluation.fleet_navigation import lattice_spacing
    from amr_evaluation.ros_episode import stop_process
    from amr_util.environment import child_environment
    from amr_util.stamps import stamp_nanoseconds

    data = world_for(robots, args.family, args.size, args.seed)
    clock: list[float] = []  # the latest /clock, s

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{data['name']}.yaml"
        path.write_text(yaml.safe_dump(data, sort_keys=False))
        profile = Path(folder) / "profile.json"
        context = rclpy.Context()
        rclpy.init(context=context)
        node = rclpy.create_node("bench_fleet_ros_clock", context=context)
        node.create_subscription(Clock, "/clock", lambda m: clock.append(stamp_nanoseconds(m.clock) * 1e-9), 10)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        log = open(Path(folder) / "bringup.log", "w+")
        bringup = [
            "fleet_navigation",
            f"world:={path}",
            "coordination:=plan",
            f"lattice_spacing:={lattice_spacing(data, args.family)}",
            "--composed",
        ]
        profiled = args.profile or args.cprofile
        sampled = [str(profile), str(args.startup), str(args.measure), str(args.hz)] if profiled else ["-"] * 4
        profiler = "cprofile" if args.cprofile else "sample"
        process = subprocess.Popen(
            [sys.executable, __file__, "--child", *sampled, args.executor, profiler, "--", *bringup],
            env=child_environment(),
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        result = {"robots": robots, "world": data["name"], "load": os.getloadavg()[0]}
        try:
            began, running = time.monotonic(), None
            while running is None or time.monotonic() - running < args.warmup:
                executor.spin_once(timeout_sec=0.1)
                if process.poll() is not None or time.monotonic() - began > args.startup:
                    return result  # amr-bringup exited early or never ran: its log's tail is printed
                if running is None and clock and clock[-1] >= args.from_sim:
                    running = time.monotonic()  # the stack is up and past the start
            profile.with_suffix(".go").touch()
            sim0, wall0, cpu0 = (clock[-1] if clock else 0.0), time.monotonic(), _cpu_seconds(process.pid)
            while time.monotonic() - wall0 < args.measure:
                executor.spin_once(timeout_sec=0.1)
            sim1, wall1, cpu1 = (clock[-1] if clock else 0.0), time.monotonic(), _cpu_seconds(process.pid)
            steps = (sim1 - sim0) / DT
            result.update(
                sim=sim1 - sim0,
                wall=wall1 - wall0,
                rtf=(sim1 - sim0) / (wall1 - wall0),
                cpu=cpu1 - cpu0,
                cpu_per_robot_step_ms=1e3 * (cpu1 - cpu0) / max(1.0, steps * robots),
                sim_at_start=sim0,
            )
            if profiled:
                deadline = time.monotonic() + 30.0
                while not profile.exists() and time.monotonic() < deadline:
                    executor.spin_once(timeout_sec=0.2)
                result["profile"] = json.loads(profile.read_text()) if profile.exists() else None
        finally:
            stop_process(process, timeout=60.0)
            log.seek(0)
            result["log_tail"] = log.read()[-2000:]
            log.close()
            executor.shutdown()
            node.destroy_node()
            context.try_shutdown()
    return result


LAYERS = (
    (
        "executor (wait set, task machinery, taking)",
        ("rclpy/executors.py", "rclpy/task.py", "rclpy/waitable.py", "amr_util/lean_executor.py"),
    ),
    ("taking messages (deserialize)", ("rclpy/subscription.py", "_take", "rclpy/impl")),
    ("publishing (serialize + DDS write)", ("rclpy/publisher.py",)),
    ("message classes (Python fields)", ("_msg/", "_msg.py")),
)


def _layer(function: str) -> str:
    for name, needles in LAYERS:
        if any(needle in function for needle in needles):
            return name
    head = function.split("/")[0]
    return f"our code: {head}" if head.startswith("amr_") else f"other: {head.split(':')[0]}"


def _kind(thread: str) -> str:
    name = thread.removeprefix("spin ").lstrip("/")
    return name.split("/")[-1] if name != thread else thread


def report_functions(profile: dict, top: int) -> None:
    """--cprofile's figures: the functions by own CPU, and ours by inclusive CPU (shares of the threads' total)."""
    rows = profile["functions"]
    total = sum(row[2] for row in rows) or 1.0
    print(f"  cProfile: {total:.1f} s of CPU in {profile['threads']} threads over {profile['duration']:.0f} s")
    print("  top functions, own CPU (calls):")
    for function, calls, own, _ in sorted(rows, key=lambda row: -row[2])[:top]:
        print(f"    {100 * own / total:5.1f} %  {function} ({calls})")
    print("  top functions of ours, inclusive:")
    ours = [row for row in rows if row[0].startswith("amr_")]
    for function, calls, _, inclusive in sorted(ours, key=lambda row: -row[3])[:top]:
        print(f"    {100 * inclusive / total:5.1f} %  {function} ({calls})")


def report(result: dict, top: int) -> None:
    profile = result.get("profile")
    if profile and "functions" in profile:
        report_functions(profile, top)
        return
    if "profile" in result and not profile:
        print(f"  no profile was written; the stack's log ends:\n{result['log_tail']}")
    if not profile:
        return
    total = sum(profile["threads"].values()) or 1.0
    kinds: dict[str, float] = defaultdict(float)
    for thread, cpu in profile["threads"].items():
        kinds[_kind(thread)] += cpu
    busy = sum(profile["self"].values()) or 1.0
    print(
        f"  threads' CPU {total:.1f} s in {profile['duration']:.0f} s ({profile['process_cpu']:.1f} s process CPU); "
        f"{busy:.1f} s of threads found busy (the shares below are of these)"
    )
    print("  by node kind: " + ", ".join(f"{k} {100 * v / total:.0f} %" for k, v in sorted(kinds.items(), key=_neg)))
    layers: dict[str, float] = defaultdict(float)
    for function, cpu in profile["self"].items():
        layers[_layer(function)] += cpu
    print("  by layer (self): " + ", ".join(f"{k} {100 * v / busy:.0f} %" for k, v in sorted(layers.items(), key=_neg)))
    every = profile.get("wakes", {})
    wakes = {t: n for t, n in every.items() if not t.startswith("waits ")}
    waits = {t.removeprefix("waits "): n for t, n in every.items() if t.startswith("waits ")}
    seconds = profile["duration"]
    steps = result["sim"] / DT * result["robots"] or 1.0
    print(f"  wait sets built and waited on per robot-step: {sum(waits.values()) / steps:.1f}")
    print(
        "  spin_once per s (all nodes of a kind) and entities per executor: "
        + ", ".join(
            f"{_kind(t)} {n / seconds:.0f}/s {profile['entities'].get(t, {})}"
            for t, n in sorted(wakes.items(), key=_neg)
        )
    )
    callbacks = profile.get("callbacks", {})
    print(f"  callbacks per robot-step: {sum(callbacks.values()) / steps:.1f}; the most frequent (all robots):")
    for key, n in sorted(callbacks.items(), key=_neg)[:top]:
        print(f"    {n / steps:5.2f}  {key}")
    print("  top functions, self:")
    for function, cpu in sorted(profile["self"].items(), key=_neg)[:top]:
        print(f"    {100 * cpu / busy:5.1f} %  {function}")
    print("  top functions of ours, inclusive:")
    ours = [(f, c) for f, c in profile["inclusive"].items() if f.startswith("amr_")]
    for function, cpu in sorted(ours, key=_neg)[:top]:
        print(f"    {100 * cpu / busy:5.1f} %  {function}")


def _neg(item) -> float:
    return -item[1]


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--child":
        return child(argv[1:])
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", type=int, default=[5, 10, 20])
    parser.add_argument("--family", default="pillars")
    parser.add_argument("--size", type=float, help="m a side (default: 4 m, more beyond 6 robots)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--startup", type=float, default=300.0, help="s of wall clock the stack may take to start")
    parser.add_argument("--from-sim", type=float, default=20.0, help="s simulated before the warm-up (localized)")
    parser.add_argument("--warmup", type=float, default=5.0, help="s of wall clock after --from-sim")
    parser.add_argument("--measure", type=float, default=40.0, help="s of wall clock measured")
    parser.add_argument("--profile", action="store_true", help="sample the child's threads while measuring")
    parser.add_argument("--cprofile", action="store_true", help="profile every thread by function (cProfile)")
    parser.add_argument("--hz", type=float, default=50.0, help="samples per second with --profile")
    parser.add_argument("--top", type=int, default=15)
    parser.add_argument(
        "--executor", choices=("lean", "stock"), default="lean", help="stock: rclpy's SingleThreadedExecutor (A/B)"
    )
    parser.add_argument("--json", type=Path, help="write every run's figures (and profile) here")
    args = parser.parse_args(argv)
    print(
        f"fleet_navigation --composed ({args.executor} executor), coordination plan, {args.family}, warm-up "
        f"{args.warmup:g} s, measured {args.measure:g} s of wall clock, load {os.getloadavg()[0]:.1f}"
    )
    print("robots  world                       sim s at start  x real time  CPU s  ms CPU per robot-step  load")
    results = []
    for robots in args.robots:
        result = run(robots, args)
        results.append(result)
        if "rtf" not in result:
            print(f"{robots:6d}  failed:\n{result['log_tail']}")
            continue
        print(
            f"{robots:6d}  {result['world']:26s}  {result['sim_at_start']:14.1f}  {result['rtf']:10.2f}x  "
            f"{result['cpu']:5.1f}  {result['cpu_per_robot_step_ms']:21.2f}  {result['load']:4.1f}",
            flush=True,
        )
        report(result, args.top)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
