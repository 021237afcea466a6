"""A clean clone's setup and test run, step by step: the README's `make test` as CI runs it.

    python bench/bench_setup.py [--dir /tmp/bench-setup] [--test [--workers N]] [--keep]

Clones this repository's HEAD (committed work only) into --dir and runs there what `make test` runs, one Makefile
step at a time: the venv and pip (`make .venv/.deps-installed`), the ROS layout and amr_interfaces
(`make setup`), and with --test lint and the suite (`make test`, which finds setup done). One line per step: wall
time, CPU time (its processes and theirs) and the load average before and after. On a shared machine the wall time
is an upper bound; the CPU time is what the step costs, and the step's line gives the load average's range while it
ran (sampled every 5 s) and, for the test step, pytest's summary line and the files that took the most CPU
(tests/conftest.py's AMR_TEST_CPU record, kept beside the clone as <dir>-cpu.txt) with the run's timeline (the
numba warm-up, each worker's first and last test, the files that ended last). Each step also says how many cores
the whole machine kept busy meanwhile and how many of them were the step's: on a shared machine the difference is
the other users'. pip downloads what its cache lacks.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def load() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def one_minute_load() -> float:
    return float(Path("/proc/loadavg").read_text().split()[0])


def busy_and_total() -> tuple[int, int]:
    """The machine's CPU time so far (/proc/stat, all cores, in ticks): busy, and busy plus idle."""
    ticks = [int(field) for field in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]
    idle = ticks[3] + ticks[4]  # idle, iowait
    return sum(ticks[:8]) - idle, sum(ticks[:8])


HEAVIEST = 10
"""files listed after the test step, the most CPU first"""


def heaviest_files(record: Path, count: int = HEAVIEST) -> str:
    """The `count` test files of most CPU in an AMR_TEST_CPU record (tests/conftest.py), the record's total and its
    timeline (support.schedule.timeline: the warm-up, the workers' collection, first and last test, the tail)."""
    sys.path.insert(0, str(ROOT / "tests"))
    from support.schedule import seconds_per_file, timeline

    with record.open(encoding="utf-8") as lines:
        per_file = seconds_per_file(lines)
    listed = ", ".join(f"{name} {seconds:.0f} s" for name, seconds in list(per_file.items())[:count])
    with record.open(encoding="utf-8") as lines:
        times = "\n".join(f"{'':10s} {line}" for line in timeline(lines, tail=4))
    return f"tests' CPU {sum(per_file.values()):.0f} s in {len(per_file)} files; the most: {listed}\n{times}"


def step(name: str, command: list[str], cwd: Path, env: dict[str, str], log: Path) -> tuple[float, float, bool]:
    before, cpu, started, ticks = load(), children_cpu(), time.monotonic(), busy_and_total()
    samples, done = [one_minute_load()], threading.Event()

    def sample() -> None:
        while not done.wait(5.0):
            samples.append(one_minute_load())

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    with log.open("w") as out:
        result = subprocess.run(command, cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT)
    done.set()
    sampler.join()
    wall, cpu = time.monotonic() - started, children_cpu() - cpu
    busy, total = (after - then for after, then in zip(busy_and_total(), ticks, strict=True))
    cores = os.cpu_count() or 1
    status = "ok" if result.returncode == 0 else f"FAILED ({result.returncode}, see {log})"
    print(
        f"{name:10s} {wall:7.1f} s wall {cpu:7.1f} s CPU  load {before} -> {load()} "
        f"(1-min {min(samples):.1f}-{max(samples):.1f} while it ran)  {status}\n"
        f"{'':10s} cores busy {cores * busy / max(total, 1):.2f} of {cores} on average, this step's "
        f"{cpu / wall:.2f} of them",
        flush=True,
    )
    summary = [line for line in log.read_text(errors="replace").splitlines() if " passed" in line or " failed" in line]
    if name == "test" and summary:
        print(f"{'':10s} pytest: {summary[-1].strip('= ')}", flush=True)
    return wall, cpu, result.returncode == 0


def machine_speed() -> float:
    """Seconds of this process's CPU for a fixed pure-Python workload: the machine's speed at the moment, to read
    a run's CPU and wall figures by (the same code took 25-30 % more CPU in one clean clone than in another an hour
    earlier on this shared machine, with no other process running and no steal time)."""
    started = time.process_time()
    total = 0
    for value in range(10_000_000):
        total += value * value % 7
    return time.process_time() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dir", type=Path, default=Path("/tmp/bench-setup"), help="the scratch clone (replaced)")
    parser.add_argument("--test", action="store_true", help="also `make test` (lint and the whole suite)")
    parser.add_argument("--keep", action="store_true", help="keep the clone afterwards")
    parser.add_argument("--workers", type=int, help="pytest-xdist workers of the test step (make test TEST_WORKERS=)")
    args = parser.parse_args()

    shutil.rmtree(args.dir, ignore_errors=True)
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(args.dir)], check=True)
    # the clone's own tools, not this interpreter's ROS environment
    env = {k: v for k, v in os.environ.items() if k not in ("LD_LIBRARY_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE")}
    venv = env.pop("VIRTUAL_ENV", None)
    if venv:  # an activated venv's paths (its setup.bash put it on AMENT_PREFIX_PATH): not the clone's
        for key in ("AMENT_PREFIX_PATH", "PATH"):
            kept = [part for part in env.get(key, "").split(os.pathsep) if part and not part.startswith(venv)]
            if kept:
                env[key] = os.pathsep.join(kept)
            else:
                env.pop(key, None)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=args.dir, capture_output=True, text=True)
    print(f"clean clone of {commit.stdout.strip()} in {args.dir}, {os.cpu_count()} cores", flush=True)
    print(f"machine speed before: {machine_speed():.2f} s of CPU for the fixed workload (bench_setup.machine_speed)")
    record = args.dir.parent / f"{args.dir.name}-cpu.txt"
    record.unlink(missing_ok=True)
    env["AMR_TEST_CPU"] = str(record)
    steps = [("pip", ["make", ".venv/.deps-installed"]), ("setup", ["make", "setup"])]
    if args.test:
        steps.append(("test", ["make", "test", *([f"TEST_WORKERS={args.workers}"] if args.workers else [])]))
    total_wall = total_cpu = 0.0
    ok = True
    for name, command in steps:
        wall, cpu, ok = step(name, command, args.dir, env, args.dir.parent / f"{args.dir.name}-{name}.log")
        total_wall, total_cpu = total_wall + wall, total_cpu + cpu
        if name == "test" and record.is_file():
            print(f"{'':10s} {heaviest_files(record)}", flush=True)
        if not ok:
            break
    print(f"{'total':10s} {total_wall:7.1f} s wall {total_cpu:7.1f} s CPU")
    print(f"machine speed after: {machine_speed():.2f} s of CPU for the fixed workload")
    if not args.keep:
        shutil.rmtree(args.dir, ignore_errors=True)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
