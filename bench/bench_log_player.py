"""How fast the log_player publishes a log in lockstep when the consumer answers at once.

    .venv/bin/python bench/bench_log_player.py [--scans 10000] [--beams 181] [--log FILE]

Writes a CARMEN log of --scans scans (or plays --log), reads it, synthesizes the odometry, then plays it through
the log_player node with a consumer node that answers every scan with a LocalizedPose at once, both in one
process on one SingleThreadedExecutor. Prints the read, synthesis and play times and the scans per second.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", "77")

import rclpy
from lifecycle_msgs.msg import Transition
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from amr_datasets.carmen import read_carmen
from amr_datasets.odometry import synthesize_odometry
from amr_datasets.player_node import LogPlayerNode
from amr_interfaces.msg import LocalizedPose

ROOT = Path(__file__).resolve().parents[1]


def _load_test_helper(name: str):
    """The tests' module `name` (tests/support/<name>.py), loaded from its file: tests/ is no package."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "tests" / "support" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


write_log = _load_test_helper("carmen_logs").write_log


class Answerer(Node):
    def __init__(self, context) -> None:
        super().__init__("answerer", context=context)
        self.count = 0
        self.pose = self.create_publisher(LocalizedPose, "pose", 10)
        self.create_subscription(LaserScan, "scan", self._on_scan, qos_profile_sensor_data)

    def _on_scan(self, message: LaserScan) -> None:
        self.count += 1
        answer = LocalizedPose()
        answer.header.stamp = message.header.stamp
        self.pose.publish(answer)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=10_000)
    parser.add_argument("--beams", type=int, default=181)
    parser.add_argument("--log", type=Path, help="play this log instead of a written one")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as directory:
        path = args.log
        if path is None:
            path = Path(directory) / "bench.log.gz"
            write_log(path, count=args.scans, beams=args.beams, gzipped=True)
        began = time.perf_counter()
        log = read_carmen(path)
        read = time.perf_counter() - began
        began = time.perf_counter()
        synthesize_odometry(log.poses(), seed=0)
        synthesis = time.perf_counter() - began
        print(
            f"{path.name}: {len(log)} scans of {len(log.scans[0].scan.ranges)} beams read in {read:.2f} s, "
            f"odometry synthesized in {synthesis * 1e3:.1f} ms"
        )
        context = rclpy.Context()
        rclpy.init(context=context)
        executor = SingleThreadedExecutor(context=context)
        player = LogPlayerNode(context=context, parameter_overrides=[Parameter("log", value=str(path))])
        answerer = Answerer(context)
        executor.add_node(player)
        executor.add_node(answerer)
        player.try_transition(Transition.TRANSITION_CONFIGURE)
        deadline = time.monotonic() + 10.0
        while not player.count_subscribers("scan") and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        began = time.perf_counter()
        player.try_transition(Transition.TRANSITION_ACTIVATE)
        while not player.done:
            executor.spin_once(timeout_sec=0.1)
        wall = time.perf_counter() - began
        print(
            f"lockstep: {player.published} scans in {wall:.2f} s: {player.published / wall:.0f} scans/s, "
            f"{player.timeouts} pace timeouts, {answerer.count} answered; load average "
            f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
        )
        executor.shutdown()
        player.destroy_node()
        answerer.destroy_node()
        context.try_shutdown()


if __name__ == "__main__":
    main()
