"""A CARMEN log played by the log_player into the particle filter in lockstep, tracking from the first pose.

    .venv/bin/python bench/bench_log_localization.py [--log FILE] [--count N] [--particles N]

The map is the log's own scans drawn at their corrected poses (5 cm cells, endpoints occupied): optimistic, a
check that the player, the synthesized odometry (defaults, seed 0) and the filter work together, not a score.
Prints the scans played, wall time, pace timeouts and the position error of /pose against ground_truth.
"""
import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", "78")

import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from amr_interfaces.msg import LocalizedPose  # noqa: E402
from geometry_msgs.msg import PoseWithCovarianceStamped  # noqa: E402
from lifecycle_msgs.msg import Transition  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from amr_datasets.carmen import read_carmen  # noqa: E402
from amr_datasets.player_node import LogPlayerNode  # noqa: E402
from amr_localization.particle_filter_node import ParticleFilterNode  # noqa: E402
from amr_maps.map_io import save_map  # noqa: E402
from amr_maps.occupancy_grid import OccupancyGrid  # noqa: E402
from amr_util.stamps import stamp_nanoseconds  # noqa: E402

RESOLUTION = 0.05


def log_map(log, path: Path) -> None:
    """The scans' endpoints at their corrected poses, as an occupancy grid saved for map_server."""
    points = []
    for item in log.scans:
        ranges = np.asarray(item.scan.ranges)
        angles = item.scan.angle_min + item.scan.angle_increment * np.arange(ranges.size)
        hit = np.isfinite(ranges)
        x, y, theta = item.pose
        points.append(np.column_stack([x + ranges[hit] * np.cos(theta + angles[hit]),
                                       y + ranges[hit] * np.sin(theta + angles[hit])]))
    points = np.concatenate(points)
    low, high = points.min(0) - 1.0, points.max(0) + 1.0
    width, height = np.ceil((high - low) / RESOLUTION).astype(int)
    cells = np.zeros((height, width), np.int8)
    index = ((points - low) / RESOLUTION).astype(int)
    cells[index[:, 1], index[:, 0]] = 100
    save_map(OccupancyGrid(cells, RESOLUTION, (float(low[0]), float(low[1]), 0.0)), path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--log", default="/work/shared/data/carmen/intel-corrected.log.gz")
    parser.add_argument("--count", type=int, default=0, help="scans to play (0: all)")
    parser.add_argument("--particles", type=int, default=2000)
    args = parser.parse_args()
    log = read_carmen(args.log)
    directory = Path(tempfile.mkdtemp())
    log_map(log, directory / "map.yaml")
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    speed = 2.0 * float(np.max(np.hypot(*np.diff(log.poses()[:, :2], axis=0).T) / np.diff(log.stamps())))
    localizer = ParticleFilterNode(context=context, parameter_overrides=[
        Parameter("map_yaml", value=str(directory / "map.yaml")),
        Parameter("laser_max_range", value=float(log.scans[0].scan.range_max)),
        Parameter("max_particles", value=args.particles), Parameter("max_odometry_speed", value=min(speed, 100.0))])
    player = LogPlayerNode(context=context, parameter_overrides=[Parameter("log", value=args.log),
                                                                 Parameter("count", value=args.count)])
    watcher = Node("watcher", context=context)
    truth, estimates = {}, {}
    watcher.create_subscription(Odometry, "ground_truth",
                                lambda m: truth.__setitem__(stamp_nanoseconds(m.header.stamp), m), 1000)
    watcher.create_subscription(LocalizedPose, "pose",
                                lambda m: estimates.__setitem__(stamp_nanoseconds(m.header.stamp), m), 1000)
    initial = watcher.create_publisher(PoseWithCovarianceStamped, "initialpose", 10)
    for node in (localizer, player, watcher):
        executor.add_node(node)
    for node in (localizer, player):
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.get_name()
    assert localizer.try_transition(Transition.TRANSITION_ACTIVATE)
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and (
            player.count_subscribers("scan") < 2 or not initial.get_subscription_count()):
        executor.spin_once(timeout_sec=0.05)
    x0, y0, theta0 = log.scans[0].pose
    start = PoseWithCovarianceStamped()
    start.header.frame_id = "map"
    start.pose.pose.position.x, start.pose.pose.position.y = x0, y0
    start.pose.pose.orientation.z, start.pose.pose.orientation.w = math.sin(theta0 / 2), math.cos(theta0 / 2)
    start.pose.covariance[0] = start.pose.covariance[7] = start.pose.covariance[35] = 0.01
    initial.publish(start)
    for _ in range(10):
        executor.spin_once(timeout_sec=0.05)
    began = time.monotonic()
    assert player.try_transition(Transition.TRANSITION_ACTIVATE)
    while not player.done:
        executor.spin_once(timeout_sec=0.1)
    wall = time.monotonic() - began
    errors = [math.hypot(truth[k].pose.pose.position.x - m.pose.pose.position.x,
                         truth[k].pose.pose.position.y - m.pose.pose.position.y)
              for k, m in estimates.items() if k in truth]
    print(f"{Path(args.log).name}: {player.published} scans in {wall:.1f} s ({player.published / wall:.0f}/s), "
          f"{player.timeouts} pace timeouts, {len(estimates)} poses; position error median {np.median(errors):.3f} m, "
          f"90 % {np.percentile(errors, 90):.3f} m, max {np.max(errors):.3f} m; {args.particles} particles, load "
          f"average {os.getloadavg()[0]:.1f}")
    executor.shutdown()
    context.try_shutdown()


if __name__ == "__main__":
    main()
