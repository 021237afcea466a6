"""The order in which a parallel run hands its test files out: the longest first (tests/conftest.py).

`make test` runs `pytest -n 4 --dist loadfile --no-loadscope-reorder`: each worker takes a whole file at a time, in
collection order. pytest-xdist's own order (without `--no-loadscope-reorder`) is by the number of tests, which put
the longest files, a single test each (colcon building the interfaces, the demo), last: one worker ran them alone
while the other had finished. Handed out longest first, the files left at the end are short ones and the workers
finish close together. A file not in SECONDS counts as short (0 s) and keeps its place among the short ones.

Refresh SECONDS from a run's `--durations=0` lines or its AMR_TEST_CPU record: `python -m support.schedule
durations.txt` (from tests/) prints each file's summed seconds, longest first; `python -m support.schedule --walls
cpu.txt` each file's seconds on its worker (from its first test's start to its last one's end) in an AMR_TEST_CPU
record. Only the order matters, not the figures. `python -m support.schedule --timeline cpu.txt` reads an
AMR_TEST_CPU record of a parallel run as a timeline: the numba warm-up, each worker's collection, first and last test
and its waits, and the files that ended last (the tail).
"""

from __future__ import annotations

import re
import sys
from collections import defaultdict
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]

SECONDS = {
    "viewer/test_browser.py": 151,
    "foundation/test_colcon_build.py": 106,
    "bringup/test_realtime_stacks.py": 62,
    "evaluation/test_localization_closed_loop.py": 46,
    "evaluation/test_fleet_plan_runs.py": 44,
    "bringup/test_fleet_traffic.py": 37,
    "control_node/test_closed_loop_ros.py": 36,
    "control/test_closed_loop.py": 30,
    "bringup/test_bringup_run.py": 26,
    "bringup/test_demo.py": 21,
    "util/test_lifecycle_edges.py": 21,
    "bringup/test_recording.py": 20,
    "evaluation/test_ros_episode.py": 26,
    "foundation/test_docs.py": 17,
    "simulation/test_simulator_node_controls.py": 14,
    "evaluation/test_symmetry_closed_loop.py": 13,
    "kinematics_node/test_ik_service_process.py": 13,
    "evaluation/test_command_controller.py": 13,
    "evaluation/test_fleet_traffic_runs.py": 12,
    "planning_node/test_plan_and_follow_ros.py": 12,
    "evaluation/test_sweep_input.py": 10,
    "evaluation/test_episode.py": 9,
    "localization/test_particle_filter.py": 9,
    "simulation/test_simulator_node.py": 9,
    "bringup/test_real_robot_navigation.py": 8,
    "control/test_wall_follower_route.py": 8,
    "evaluation/test_crowded_localization.py": 8,
    "evaluation/test_runner.py": 7,
    "simulation/test_simulator_node_fleet.py": 7,
    "planning/test_fleet_lacam.py": 6,
    "kinematics_node/test_ik_service_fuzz.py": 6,
    "simulation/test_fleet.py": 6,
    "kinematics/test_compiled.py": 6,
    "control_node/test_wall_follower_node.py": 6,
    "turtlebot3/test_odometry_node.py": 6,
    "foundation/test_without_pymunk.py": 6,
    "simulation/test_simulator_node_resend.py": 5,
    "mapping/test_slam.py": 5,
    "evaluation/test_gym_env.py": 4,
    "simulation/test_simulator_node_process.py": 4,
    "maps/test_maze_families.py": 4,
    "navigation/test_nobody_drives.py": 4,
    "kinematics_node/test_ik_service_lifecycle.py": 4,
    "foundation/test_declared_dependencies.py": 3,
}
"""Seconds a worker spends on the file (tests/-relative path): from its first test's start to its last one's end in a
clean clone's run (bee98e7, two workers, load 1-6: `--walls` of its AMR_TEST_CPU record; test_fleet_traffic.py less
the 10 s its deadlocked run no longer waits); files under 3 s are left out."""

WITHOUT_KERNELS = (
    "foundation/test_colcon_build.py",
    "viewer/test_browser.py::test_a_page_without_webgl",
    "viewer/test_browser.py::test_a_page_whose_first_connection_failed",
)
"""Tests (tests/-relative node ids, or their beginnings) that call no numba kernel, in this process or a node process:
a parallel run's first ones (the longest files first) run while the kernels are compiled (tests/conftest.py)."""


def file_of(item) -> str:
    """The test file of a collected item, relative to tests/ ("viewer/test_browser.py")."""
    path = Path(item.path)
    return path.relative_to(TESTS).as_posix() if path.is_relative_to(TESTS) else path.as_posix()


def calls_no_kernel(item) -> bool:
    """Whether the item is one of WITHOUT_KERNELS."""
    return f"{file_of(item)}::{item.name}".startswith(WITHOUT_KERNELS)


def longest_files_first(items: list) -> list:
    """The items ordered by their file's SECONDS, longest first; a file's tests stay together and in their order,
    files of equal seconds in collection order."""
    first_seen: dict[str, int] = {}
    for item in items:
        first_seen.setdefault(file_of(item), len(first_seen))

    def key(item) -> tuple[float, int]:
        name = file_of(item)
        return -SECONDS.get(name, 0), first_seen[name]

    return sorted(items, key=key)


DURATION = re.compile(r"^\s*([0-9.]+)s\s+(?:setup|call|teardown|cpu)\s+(?:tests/)?([^:\s]+)::")


def seconds_per_file(lines) -> dict[str, float]:
    """Each file's summed seconds from pytest's `--durations=0` lines (or AMR_TEST_CPU's, tests/conftest.py),
    longest first."""
    total: dict[str, float] = defaultdict(float)
    for line in lines:
        match = DURATION.match(line)
        if match:
            total[match.group(2)] += float(match.group(1))
    return dict(sorted(total.items(), key=lambda entry: -entry[1]))


RECORDED = re.compile(r"^([0-9.]+)s cpu (\S+) (\S+) ([0-9.]+) ([0-9.]+)$")
"""An AMR_TEST_CPU line: CPU seconds, node id, worker, start and end (epoch seconds)."""


def timeline(lines, tail: int = 8) -> list[str]:
    """An AMR_TEST_CPU record of a parallel run as lines to print, in seconds from the controller's start of the
    numba warm-up (or the first test): the warm-up, each worker's collection, first test, last end, CPU (and its share
    of one core from first test to last end: on idle cores, what the worker's tests did not wait) and the seconds it
    waited for the warm-up, and the `tail` files that ended last (worker, start, end, CPU)."""
    marks: dict[str, tuple[float, ...]] = {}
    waited: dict[str, float] = defaultdict(float)
    tests = []
    for line in lines:
        words = line.split()
        if line.startswith("# warm-up"):
            marks["warm-up"] = (float(words[2]), float(words[3]))
        elif line.startswith("# collected"):
            marks[f"{words[2]} collected"] = (float(words[3]),)
        elif line.startswith("# waited"):
            waited[words[2]] += float(words[4]) - float(words[3])
        elif match := RECORDED.match(line.strip()):
            cpu, nodeid, worker, start, end = match.groups()
            tests.append((float(cpu), nodeid.split("::")[0], worker, float(start), float(end)))
    if not tests:
        return ["no timed tests in the record (AMR_TEST_CPU of a run with this conftest)"]
    zero = marks.get("warm-up", (min(test[3] for test in tests),))[0]
    out = [f"{name}: {', '.join(f'{t - zero:.1f}' for t in times)} s" for name, times in sorted(marks.items())]
    for worker in sorted({test[2] for test in tests}):
        mine = [test for test in tests if test[2] == worker]
        first, last = min(t[3] for t in mine) - zero, max(t[4] for t in mine) - zero
        cpu = sum(t[0] for t in mine)
        out.append(
            f"{worker}: first test {first:.1f} s, last end {last:.1f} s, {cpu:.0f} s of CPU in {len(mine)} tests"
            f" ({cpu / max(last - first, 1e-9):.0%} of a core), {waited[worker]:.1f} s waiting for the warm-up"
        )
    files: dict[str, list] = {}
    for cpu, name, worker, start, end in sorted(tests, key=lambda test: test[3]):
        entry = files.setdefault(name, [worker, start, end, 0.0])
        entry[2], entry[3] = max(entry[2], end), entry[3] + cpu
    out.append("files that ended last (worker, start, end, CPU):")
    for name, (worker, start, end, cpu) in sorted(files.items(), key=lambda item: item[1][2])[-tail:]:
        out.append(f"  {name} {worker} {start - zero:.1f}-{end - zero:.1f} s, {cpu:.1f} s of CPU")
    return out


def walls_per_file(lines) -> dict[str, float]:
    """Each file's seconds on its worker in an AMR_TEST_CPU record (its first test's start to its last one's end),
    tests/-relative, longest first."""
    spans: dict[str, list[float]] = {}
    for line in lines:
        if match := RECORDED.match(line.strip()):
            name = match.group(2).split("::")[0].removeprefix("tests/")
            start, end = float(match.group(4)), float(match.group(5))
            span = spans.setdefault(name, [start, end])
            span[:] = [min(span[0], start), max(span[1], end)]
    return dict(sorted(((name, end - start) for name, (start, end) in spans.items()), key=lambda entry: -entry[1]))


if __name__ == "__main__":
    if sys.argv[1] in ("--timeline", "--walls"):
        with open(sys.argv[2], encoding="utf-8") as record:
            if sys.argv[1] == "--timeline":
                print("\n".join(timeline(record)))
            else:
                print("\n".join(f'    "{name}": {s:.0f},' for name, s in walls_per_file(record).items() if s >= 3))
        sys.exit()
    with open(sys.argv[1], encoding="utf-8") as durations:
        for name, seconds in seconds_per_file(durations).items():
            if seconds >= 3:
                print(f'    "{name}": {seconds:.0f},')
