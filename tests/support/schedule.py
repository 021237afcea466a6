"""The order in which a parallel run hands its test files out: the longest first (tests/conftest.py).

`make test` runs `pytest -n 2 --dist loadfile --no-loadscope-reorder`: each worker takes a whole file at a time, in
collection order. pytest-xdist's own order (without `--no-loadscope-reorder`) is by the number of tests, which put
the longest files, a single test each (colcon building the interfaces, the demo), last: one worker ran them alone
while the other had finished. Handed out longest first, the files left at the end are short ones and the two workers
finish close together. A file not in SECONDS counts as short (0 s) and keeps its place among the short ones.

Refresh SECONDS from a run's `--durations=0` lines: `python -m support.schedule durations.txt` (from tests/)
prints each file's summed seconds, longest first. Only the order matters, not the figures.
"""

from __future__ import annotations

import re
import sys
from collections import defaultdict
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]

SECONDS = {
    "viewer/test_browser.py": 139,
    "foundation/test_colcon_build.py": 85,
    "bringup/test_fleet_traffic.py": 68,
    "evaluation/test_localization_closed_loop.py": 59,
    "evaluation/test_fleet_plan_runs.py": 59,
    "control_node/test_closed_loop_ros.py": 37,
    "control/test_closed_loop.py": 37,
    "bringup/test_demo.py": 28,
    "foundation/test_docs.py": 23,
    "bringup/test_realtime_stacks.py": 22,
    "evaluation/test_ros_episode.py": 21,
    "evaluation/test_crowded_localization.py": 20,
    "util/test_lifecycle_edges.py": 20,
    "bringup/test_bringup_run.py": 19,
    "planning_node/test_plan_and_follow_ros.py": 18,
    "bringup/test_recording.py": 16,
    "evaluation/test_fleet_traffic_runs.py": 15,
    "evaluation/test_symmetry_closed_loop.py": 15,
    "foundation/test_without_pymunk.py": 14,
    "localization/test_particle_filter.py": 13,
    "simulation/test_simulator_node_controls.py": 13,
    "evaluation/test_episode.py": 11,
    "bringup/test_real_robot_navigation.py": 11,
    "evaluation/test_sweep_input.py": 11,
    "planning/test_fleet_lacam.py": 10,
    "foundation/test_declared_dependencies.py": 9,
    "simulation/test_fleet.py": 9,
    "control/test_wall_follower_route.py": 9,
    "evaluation/test_runner.py": 9,
    "evaluation/test_command_controller.py": 8,
    "mapping/test_slam.py": 8,
    "kinematics_node/test_ik_service_process.py": 7,
    "kinematics/test_compiled.py": 7,
    "turtlebot3/test_odometry_node.py": 6,
    "kinematics_node/test_ik_service_fuzz.py": 6,
    "navigation/test_loop.py": 6,
    "simulation/test_simulator_node_process.py": 5,
    "evaluation/test_gym_env.py": 5,
    "simulation/test_simulator_node_resend.py": 5,
    "navigation/test_nobody_drives.py": 5,
    "maps/test_maze_families.py": 4,
    "control_node/test_wall_follower_node.py": 4,
    "simulation/test_simulator_node_fleet.py": 4,
}
"""Seconds a worker spends on the file (tests/-relative path): its processes' CPU, or its wall time where it mostly
waits. The larger of the full run of 2026-11-29 afternoon (the lifecycle edges measured alone after their windows were
shared) and a clean clone's recorded CPU that evening (AMR_TEST_CPU, load 7-13); files under 3 s are left out."""


def file_of(item) -> str:
    """The test file of a collected item, relative to tests/ ("viewer/test_browser.py")."""
    path = Path(item.path)
    return path.relative_to(TESTS).as_posix() if path.is_relative_to(TESTS) else path.as_posix()


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


if __name__ == "__main__":
    with open(sys.argv[1], encoding="utf-8") as durations:
        for name, seconds in seconds_per_file(durations).items():
            if seconds >= 3:
                print(f'    "{name}": {seconds:.0f},')
