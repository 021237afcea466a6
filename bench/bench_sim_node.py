"""Closed-loop lockstep rate of the simulator node: what a driver gets through ROS 2.

    .venv/bin/python bench/bench_sim_node.py [--steps 2000] [--world outer_corridor.yaml] [--processes]

A trivial driver (drive ahead, turn on the spot while something is within 0.3 m in
front) answers every observation (/odometry and /scan of one stamp, as the wall
follower pairs them) with the next /cmd_vel; each command advances one dt = 0.05 s.
Reported: steps per wall-clock second, the real-time factor (simulated s per wall s)
and the mean command -> observation round trip, for
  1. the library alone (Simulator.step, no ROS: the ceiling),
  2. node and driver in one process, one single-threaded executor, all topics on,
  3. the same with only /odometry and /scan published (publish_* false),
  4. with --processes: the node as `ros2 run` starts it, the driver in this process.
"""

from __future__ import annotations

import argparse
import math
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"  # before rclpy: no traffic leaves this machine
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(101, 232)))

import numpy as np
import rclpy
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from amr_simulation.simulator import Simulator
from amr_simulation.simulator_node import SimulatorNode

DT = 0.05
FRONT_HALF_WIDTH = math.radians(45.0)
BUMP_DISTANCE = 0.3  # m
STALL_TIMEOUT = 2.0  # s without an observation: the loop is reported stalled
DISCOVERY_TIMEOUT = 20.0  # s for the node process to appear
EXECUTABLE = Path(sys.prefix) / "lib" / "amr_simulation" / "simulator"


def bump_and_turn(ranges: np.ndarray, angle_min: float, increment: float) -> tuple[float, float]:
    angles = np.angle(np.exp(1j * (angle_min + increment * np.arange(ranges.size))))
    front = ranges[np.abs(angles) <= FRONT_HALF_WIDTH]
    return (0.0, 1.5) if np.any(front < BUMP_DISTANCE) else (0.2, 0.0)


class Driver(Node):
    """Sends the next command once /odometry and /scan of the same stamp have both arrived."""

    def __init__(self, context, steps: int) -> None:
        super().__init__("bench_driver", context=context)
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.cmd_vel = self.create_publisher(TwistStamped, "cmd_vel", reliable)
        self.odometry = self.create_subscription(Odometry, "odometry", self._on_odometry, reliable)
        self.scan = self.create_subscription(LaserScan, "scan", self._on_scan, qos_profile_sensor_data)
        self.target = steps
        self.observations = 0
        self.sent = 0
        self._odometry_stamp = self._scan_stamp = None
        self._command = (0.2, 0.0)

    def _on_odometry(self, message: Odometry) -> None:
        self._odometry_stamp = (message.header.stamp.sec, message.header.stamp.nanosec)
        self._maybe_answer()

    def _on_scan(self, message: LaserScan) -> None:
        self._scan_stamp = (message.header.stamp.sec, message.header.stamp.nanosec)
        ranges = np.asarray(message.ranges, dtype=float)
        self._command = bump_and_turn(ranges, message.angle_min, message.angle_increment)
        self._maybe_answer()

    def _maybe_answer(self) -> None:
        if self._odometry_stamp is None or self._odometry_stamp != self._scan_stamp:
            return
        self._odometry_stamp = self._scan_stamp = None
        self.observations += 1
        if self.sent < self.target:
            self.send()

    def send(self) -> None:
        message = TwistStamped()
        message.twist.linear.x, message.twist.angular.z = self._command
        self.cmd_vel.publish(message)
        self.sent += 1

    def connected(self) -> bool:
        return (
            self.cmd_vel.get_subscription_count() > 0
            and self.odometry.get_publisher_count() > 0
            and self.scan.get_publisher_count() > 0
        )


def run_loop(executor, driver: Driver) -> tuple[int, float]:
    """Drive until the target is reached or the loop stalls; returns (steps, wall seconds)."""
    start = time.perf_counter()
    driver.send()
    last_progress, last_count = time.perf_counter(), 0
    while driver.observations < driver.target:
        executor.spin_once(timeout_sec=0.1)
        if driver.observations != last_count:
            last_progress, last_count = time.perf_counter(), driver.observations
        elif time.perf_counter() - last_progress > STALL_TIMEOUT:
            print(f"   stalled after {driver.observations} observations (a best-effort /scan lost?)")
            break
    return driver.observations, time.perf_counter() - start


def report(label: str, steps: int, seconds: float) -> None:
    rate = steps / seconds
    print(
        f"{label:<44} {steps:6d} steps {seconds:7.2f} s {rate:8.0f} steps/s "
        f"RTF {rate * DT:6.1f}x  round trip {1e3 / rate:6.2f} ms"
    )


def bench_library(world: str, steps: int) -> None:
    sim = Simulator.from_params({"world": world, "dt": DT})
    lidar = sim.lidar
    start = time.perf_counter()
    for _ in range(steps):
        sim.step(*bump_and_turn(np.asarray(sim.ranges), lidar.angle_min, lidar.angle_increment))
    report("library alone (no ROS)", steps, time.perf_counter() - start)


def bench_in_process(world: str, steps: int, label: str, **extra) -> None:
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    params = [Parameter("world", value=world), Parameter("dt", value=DT)]
    params += [Parameter(name, value=value) for name, value in extra.items()]
    node = SimulatorNode(context=context, parameter_overrides=params)
    driver = Driver(context, steps)
    try:
        executor.add_node(node)
        executor.add_node(driver)
        node.trigger_configure()
        deadline = time.monotonic() + DISCOVERY_TIMEOUT
        while not driver.connected() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        node.trigger_activate()
        driver.observations = 0  # the activation's first observation is not a step
        report(label, *run_loop(executor, driver))
    finally:
        executor.shutdown()
        node.destroy_node()
        driver.destroy_node()
        context.try_shutdown()


def bench_processes(world: str, steps: int) -> None:
    bootstrap = ("LD_LIBRARY_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE")  # the child sets up its own library path
    environment = {k: v for k, v in os.environ.items() if k not in bootstrap}
    command = [
        str(EXECUTABLE),
        "--ros-args",
        "-p",
        "autostart:=true",
        "-p",
        f"world:={world}",
        "-p",
        f"dt:={DT}",
        "--log-level",
        "warn",
    ]
    process = subprocess.Popen(command, env=environment, start_new_session=True)
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    driver = Driver(context, steps)
    try:
        executor.add_node(driver)
        deadline = time.monotonic() + DISCOVERY_TIMEOUT
        while not driver.connected() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        end = time.monotonic() + 0.5  # let the node's writers match our readers too
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        driver.observations = 0
        report("node process + driver in this process", *run_loop(executor, driver))
    finally:
        executor.shutdown()
        driver.destroy_node()
        context.try_shutdown()
        process.send_signal(signal.SIGINT)
        process.wait(timeout=10.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--world", default="outer_corridor.yaml")
    parser.add_argument("--processes", action="store_true", help="also run the node as a separate process")
    args = parser.parse_args()
    print(f"world {args.world}, dt {DT} s, 240-beam LiDAR every step, {os.cpu_count()} CPUs")
    bench_library(args.world, args.steps)
    bench_in_process(args.world, args.steps, "node + driver, one process, all topics")
    bench_in_process(
        args.world,
        args.steps,
        "node + driver, one process, /odometry + /scan",
        publish_odom=False,
        publish_ground_truth=False,
        publish_status=False,
    )
    if args.processes:
        bench_processes(args.world, args.steps)


if __name__ == "__main__":
    main()
