"""SLAM on real robots' logs through the ROS nodes: log_player (lockstep, paced by the slam node's /pose) into the
`slam` lifecycle node, the map saved through its ~/save_map service at the end, the saved graph's poses
(<path>.poses.csv) against the player's /ground_truth at the same stamps.

    .venv/bin/python bench/bench_slam_logs_ros.py [--data DIR] [--logs intel ...] [--seeds 0]

Run it with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a ROS_DOMAIN_ID of its own. The configuration is
bench_slam_logs.py's (SlamConfig's defaults, the LiDAR where the log's poses are); the odometry the player's
(amr_datasets.odometry: 5 % noise, 1 % scale error, 0.5 deg/m heading bias, seeded), the library bench's to the bit;
/map published as the node's default does (map_publish_period 1 s of scan time: at every keyframe of these logs, the
kept map brought to the optimized poses on the node's map thread; --map-period 3600 leaves it out). Printed per log:
scans answered (a /pose for each), graph nodes, the relative displacement error of Kuemmerle et al. (pairs 1-10 m
apart) and the ATE after a rigid alignment over the saved nodes, the round trip (the player publishing a scan to the
/pose answering it reaching a watcher: p50, p95, max) and the wall time against the log's duration. Prints; asserts
nothing.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rclpy
from bench_log_localization_ros import start_consumer
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from amr_datasets.carmen import LOG_MOUNT, log_name, read_carmen
from amr_datasets.player_node import LogPlayerNode
from amr_interfaces.msg import LocalizedPose
from amr_interfaces.srv import SaveMap
from amr_mapping.slam_node import SlamNode
from amr_mapping.trajectory_error import absolute_error, relative_error
from amr_util.geometry import yaw_from_quaternion
from amr_util.stamps import stamp_nanoseconds

DATA = Path(__file__).resolve().parents[2] / "shared/data/carmen"
KEEP = 100_000


def run_through_ros(path: Path, seed: int, map_period: float = 1.0) -> str:
    log = read_carmen(path)
    name = log_name(path)
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    slam = SlamNode(
        context=context,
        parameter_overrides=[Parameter(key, value=float(value)) for key, value in LOG_MOUNT.items()]
        + [Parameter("map_publish_period", value=map_period)],
    )
    player = LogPlayerNode(
        context=context,
        parameter_overrides=[
            Parameter("log", value=str(path)),
            Parameter("seed", value=seed),
            Parameter("pace_timeout", value=60.0),
        ],
    )
    watcher = Node("watcher", context=context)
    truth, answered, scan_seen = {}, {}, {}
    watcher.create_subscription(
        Odometry, "ground_truth", lambda m: truth.__setitem__(stamp_nanoseconds(m.header.stamp), m), KEEP
    )
    watcher.create_subscription(
        LocalizedPose, "pose", lambda m: answered.__setitem__(stamp_nanoseconds(m.header.stamp), time.monotonic()), KEEP
    )
    save = watcher.create_client(SaveMap, "slam/save_map")
    for node in (slam, player, watcher):
        executor.add_node(node)
    directory = Path(tempfile.mkdtemp())
    try:
        failed = start_consumer(slam, player, scan_seen)
        if failed:
            return f"{name}: {failed} did not configure"
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and player.count_subscribers("scan") < 1:
            executor.spin_once(timeout_sec=0.05)
        started = time.monotonic()
        player.try_transition(Transition.TRANSITION_ACTIVATE)
        while not player.done:
            executor.spin_once(timeout_sec=0.1)
        for _ in range(20):
            executor.spin_once(timeout_sec=0.05)
        wall = time.monotonic() - started
        request = SaveMap.Request()
        request.path = str(directory / "map")
        future = save.call_async(request)
        deadline = time.monotonic() + 120.0
        while not future.done() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        if not future.done() or not future.result().success:
            return f"{name}: save_map failed ({future.result().message if future.done() else 'no answer'})"
        timeouts = player.timeouts
    finally:
        slam.shut_down_cleanly()  # its map thread joined
        executor.shutdown()
        context.try_shutdown()
    rows = [line.split(",") for line in (directory / "map.poses.csv").read_text().splitlines()[1:] if line]
    saved = [(int(row[0]), [float(v) for v in row[1:4]]) for row in rows if int(row[0]) in truth]  # ns: exact ints
    reference = np.array(
        [
            (m.pose.pose.position.x, m.pose.pose.position.y, yaw_from_quaternion(m.pose.pose.orientation))
            for m in (truth[stamp] for stamp, _ in saved)
        ]
    )
    estimate = np.array([pose for _, pose in saved])
    rel, ate = relative_error(estimate, reference), absolute_error(estimate, reference)
    trips = np.array([answered[s] - scan_seen[s] for s in answered if s in scan_seen]) * 1e3
    duration = log.stamps()[-1] - log.stamps()[0] if log.has_stamps else None
    speed = f"{duration / wall:.0f}x" if duration else "no stamps"
    return (
        f"{name:16s} seed {seed}: {len(answered)}/{len(log.scans)} scans answered, {timeouts} pace timeouts, "
        f"{len(saved)} nodes, rel. error {rel.translation:.3f} m {rel.rotation_deg:.2f} deg, ATE {ate.rmse:.3f} m, "
        f"round trip p50 {np.percentile(trips, 50):.0f} ms p95 {np.percentile(trips, 95):.0f} ms "
        f"max {trips.max():.0f} ms, {wall:.1f} s wall ({speed})"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--logs", nargs="*", help="log names (the file name's first word); default: every log")
    parser.add_argument("--seeds", nargs="*", type=int, default=[0])
    parser.add_argument(
        "--map-period", type=float, default=1.0, help="the slam node's map_publish_period (s of scan time; default)"
    )
    args = parser.parse_args()
    files = sorted(args.data.glob("*.log*"))
    files = [f for f in files if log_name(f) in args.logs] if args.logs else files
    if not files:
        print(f"no CARMEN log in {args.data}", file=sys.stderr)
        return 2
    for path in files:
        for seed in args.seeds:
            print(run_through_ros(path, seed, args.map_period), flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    sys.exit(main())
