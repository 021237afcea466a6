"""A CARMEN log through the ROS nodes: log_player (lockstep, paced by /pose) into particle_filter on a map_server
file of the log's map; used by bench_log_localization.py --ros (see its docstring).

The figures are the library run's (amr_evaluation.log_localization.LogRun), from /pose against /ground_truth,
plus the round trip: wall time from the player publishing a scan to the /pose answering it reaching a watcher.
"""

from __future__ import annotations

import math
import struct
import tempfile
import time
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import PoseWithCovarianceStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from amr_datasets.odometry import OdometryNoiseModel
from amr_datasets.player_node import LogPlayerNode
from amr_evaluation.log_localization import WRONG_HEADING, WRONG_POSITION, LogRun, log_parameters, range_max
from amr_interfaces.msg import LocalizedPose
from amr_localization.particle_filter_node import ParticleFilterNode
from amr_maps.map_io import save_map
from amr_util.geometry import wrap_angle, yaw_from_quaternion
from amr_util.stamps import stamp_nanoseconds

KEEP = 100_000


def time_scans(player: LogPlayerNode, seen: dict) -> None:
    """Notes in `seen` (stamp ns -> time.monotonic()) when the configured player publishes each scan: where a round
    trip starts (in this process, before any callback runs on the scan)."""
    output = player._outputs["scan"]
    publish = output.publish

    def publish_timed(message) -> None:
        if isinstance(message, bytes):  # serialized (CDR: 4 bytes of encapsulation, then the header's stamp)
            sec, nanosec = struct.unpack_from("<iI", message, 4)
            stamp = sec * 1_000_000_000 + nanosec
        else:
            stamp = stamp_nanoseconds(message.header.stamp)
        seen[stamp] = time.monotonic()
        publish(message)

    output.publish = publish_timed


def start_consumer(consumer, player: LogPlayerNode, seen: dict) -> str | None:
    """Configures the consumer of the log's scans and the player (the name of one that did not: nothing else done),
    notes when each scan is published (time_scans) and activates the consumer; the player is activated later."""
    for node in (consumer, player):
        if not node.try_transition(Transition.TRANSITION_CONFIGURE):
            return node.get_name()
    time_scans(player, seen)
    consumer.try_transition(Transition.TRANSITION_ACTIVATE)
    return None


def run_through_ros(path: Path, log, grid, name: str, parameters: dict, mode: str, seed: int) -> str:
    directory = Path(tempfile.mkdtemp())
    save_map(grid, directory / "map.yaml")
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    values = log_parameters(log, parameters, seed, OdometryNoiseModel())  # the library run's (the player's noise)
    overrides = [Parameter(key, value=value) for key, value in values.items()]
    overrides += [
        Parameter("map_yaml", value=str(directory / "map.yaml")),
        Parameter("laser_max_range", value=range_max(log)),
        Parameter("particle_cloud_period", value=3600.0),
    ]
    localizer = ParticleFilterNode(context=context, parameter_overrides=overrides)
    player = LogPlayerNode(
        context=context, parameter_overrides=[Parameter("log", value=str(path)), Parameter("seed", value=seed)]
    )
    watcher = Node("watcher", context=context)
    truth, estimates, scan_seen, pose_seen = {}, {}, {}, {}
    watcher.create_subscription(
        Odometry, "ground_truth", lambda m: truth.__setitem__(stamp_nanoseconds(m.header.stamp), m), KEEP
    )

    def on_pose(message: LocalizedPose) -> None:
        stamp = stamp_nanoseconds(message.header.stamp)
        estimates[stamp], pose_seen[stamp] = message, time.monotonic()

    watcher.create_subscription(LocalizedPose, "pose", on_pose, KEEP)
    initial = watcher.create_publisher(PoseWithCovarianceStamped, "initialpose", 10)
    for node in (localizer, player, watcher):
        executor.add_node(node)
    try:
        failed = start_consumer(localizer, player, scan_seen)
        if failed:
            return f"{name}: {failed} did not configure"
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and (
            player.count_subscribers("scan") < 2 or not initial.get_subscription_count()
        ):
            executor.spin_once(timeout_sec=0.05)
        if mode == "tracking":
            x0, y0, theta0 = log.scans[0].pose
            start = PoseWithCovarianceStamped()
            start.header.frame_id = "map"
            start.pose.pose.position.x, start.pose.pose.position.y = float(x0), float(y0)
            start.pose.pose.orientation.z, start.pose.pose.orientation.w = math.sin(theta0 / 2), math.cos(theta0 / 2)
            start.pose.covariance[0] = start.pose.covariance[7] = 0.01
            start.pose.covariance[35] = math.radians(5.0) ** 2
            initial.publish(start)
            for _ in range(20):
                executor.spin_once(timeout_sec=0.05)
        player.try_transition(Transition.TRANSITION_ACTIVATE)
        while not player.done:
            executor.spin_once(timeout_sec=0.1)
        for _ in range(20):
            executor.spin_once(timeout_sec=0.05)
    finally:
        executor.shutdown()
        context.try_shutdown()
    run = LogRun(name, mode + "/ros")
    poses = log.poses()
    travel = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
    stamps = sorted(estimates)
    for index, stamp in enumerate(stamps):
        message = estimates[stamp]
        reference = truth.get(stamp)
        if reference is None:
            continue
        p, q = message.pose.pose, reference.pose.pose
        run.travel.append(float(travel[min(index, len(travel) - 1)]))
        run.position_error.append(math.hypot(p.position.x - q.position.x, p.position.y - q.position.y))
        run.heading_error.append(
            abs(float(wrap_angle(yaw_from_quaternion(p.orientation) - yaw_from_quaternion(q.orientation))))
        )
        run.localized.append(bool(message.localized))
        run.confidence.append(float(message.confidence))
        run.update_time.append(pose_seen[stamp] - scan_seen[stamp] if stamp in scan_seen else math.nan)
    round_trip = np.array([t for t in run.update_time if math.isfinite(t)]) * 1e3
    wrong_at = [
        f"{index} ({e:.2f} m, {math.degrees(h):.1f} deg)"
        for index, (e, h, on) in enumerate(zip(run.position_error, run.heading_error, run.localized, strict=True))
        if on and (e > WRONG_POSITION or h > WRONG_HEADING)
    ]
    run.update_time = [0.0]
    position, heading = run.median_error()
    declared = "never" if run.declared_after is None else f"{run.declared_after:.1f} m"
    return (
        f"{name:8s} {run.mode:12s} {len(estimates)}/{len(log.scans)} scans answered, {player.timeouts} pace "
        f"timeouts, declared after {declared}, wrong {run.wrong}, median error {position * 100:.1f} cm "
        f"{heading:.2f} deg, round trip p50 {np.median(round_trip):.0f} ms p95 {np.percentile(round_trip, 95):.0f} "
        f"ms max {round_trip.max():.0f} ms, seed {seed}"
        + (f"; wrong at scans {', '.join(wrong_at)}" if wrong_at else "")
    )
