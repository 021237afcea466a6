"""Cost of one wall-follower step (WallFollower.compute) per scan, 240 and 360 beams. Target: <= 100 us.

Scans are recorded from the simulator library driving the controller round a
maze (realistic geometry, 1 cm noise; the lockstep harness, amr_util.harness), then replayed through a fresh
controller and timed one call at a time. The ranges are handed over the way
rclpy delivers LaserScan.ranges (array.array of float32), and as a numpy
array and a Python list for comparison.

    python bench/bench_controller.py [--world hard_maze.yaml] [--scans 2000] [--repeat 5]
"""

from __future__ import annotations

import argparse
import array
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import read_parameter_file
from amr_maps.world import load_world
from amr_simulation.config import LidarConfig, SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.harness import Harness, OneRobot, drive
from amr_util.scan import ScanData

ROOT = Path(__file__).resolve().parents[1]

CONFIG = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
TARGET_US = 100.0


def record(world: Path, beams: int, scans: int) -> list[tuple[np.ndarray, float, float, float, LidarConfig]]:
    """(ranges, v, w, stamp) of a closed-loop run, plus the LiDAR layout."""
    sim = Simulator(load_world(world), SimulationConfig(lidar=LidarConfig(beams=beams)))
    frames = []

    def keep(frame) -> None:
        observation = frame.observation
        frames.append((observation.scan.ranges, *observation.twist, observation.stamp))

    harness = Harness(OneRobot(sim), [[keep, drive(WallFollower(CONFIG))]])
    for _ in range(scans):
        harness.step()
    return frames, sim.lidar


def replay(frames, lidar, kind: str) -> list[float]:
    """Seconds per compute() call over the recorded frames."""
    convert = {
        "array.array('f')": lambda r: array.array("f", r.astype(np.float32).tobytes()),
        "numpy float64": lambda r: r,
        "list": lambda r: r.tolist(),
    }[kind]
    scans = [
        (ScanData(convert(r), lidar.angle_min, lidar.angle_increment, lidar.range_min, lidar.range_max), v, w, t)
        for r, v, w, t in frames
    ]
    follower = WallFollower(CONFIG)
    clock = time.perf_counter
    samples = []
    for scan, v, w, t in scans:
        start = clock()
        follower.compute(scan, v, w, t)
        samples.append(clock() - start)
    return samples


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--world", default="hard_maze.yaml")
    parser.add_argument("--scans", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=5, help="replays per case; the fastest median is kept")
    args = parser.parse_args()
    world = ROOT / "config" / "worlds" / args.world

    print(
        f"WallFollower.compute per scan, {args.scans} recorded scans from {args.world}, "
        f"best of {args.repeat} replays (Python {sys.version.split()[0]}, numpy {np.__version__})"
    )
    header = f"{'beams':>5}  {'ranges as':<16} {'median us':>9} {'mean us':>8} {'p99 us':>7} {'max us':>7}  target"
    print(header)
    print("-" * len(header))
    for beams in (240, 360):
        frames, lidar = record(world, beams, args.scans)
        for kind in ("array.array('f')", "numpy float64", "list"):
            runs = [replay(frames, lidar, kind) for _ in range(args.repeat)]
            best = min(runs, key=statistics.median)
            us = sorted(s * 1e6 for s in best)
            median = statistics.median(us)
            p99 = us[math.ceil(0.99 * len(us)) - 1]
            verdict = "ok" if median <= TARGET_US else "MISSED"
            print(
                f"{beams:>5}  {kind:<16} {median:9.1f} {statistics.fmean(us):8.1f} {p99:7.1f} {us[-1]:7.1f}  {verdict}"
            )


if __name__ == "__main__":
    main()
