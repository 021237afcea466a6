"""Closed-loop rate of the full ROS loop in lockstep: simulator + wall follower (+ odometry node).

In one process (the demo's composed stack on a SingleThreadedExecutor) and across processes
(`amr-bringup`, one process per node, loopback DDS), on the same world and span. Prints
simulated seconds per wall-clock second (the real-time factor) and steps per second.
"""

from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import time

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(10, 99)))

import rclpy
from rclpy.executors import SingleThreadedExecutor

from amr_bringup.demo import run_maze
from amr_interfaces.msg import SimulatorStatus
from amr_util.environment import child_environment

DT = 0.05


def in_process(world: str, span: float, odometry_node: bool) -> float:
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        summary, _ = run_maze(context, world, span, odometry_node=odometry_node, progress=False)
    finally:
        context.try_shutdown()
    return summary["speed_up"]


def across_processes(bringup: str, world: str, span: float) -> float:
    """Starts `amr-bringup <bringup>` and measures the simulated time advancing on /simulator/status."""
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("bench_observer", context=context)
    samples: list[tuple[float, float]] = []
    node.create_subscription(
        SimulatorStatus, "simulator/status", lambda m: samples.append((time.monotonic(), m.sim_time)), 100
    )
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    bringup_process = subprocess.Popen(
        [sys.executable, "-m", "amr_bringup.bringup", bringup, "--duration", str(span / 5 + 30)],
        env=child_environment(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + span / 5 + 30
        while time.monotonic() < deadline and (not samples or samples[-1][1] < span):
            executor.spin_once(timeout_sec=0.1)
    finally:
        bringup_process.terminate()
        bringup_process.wait(timeout=30)
        executor.shutdown()
        context.try_shutdown()
    started = next(i for i, (_, t) in enumerate(samples) if t >= 5.0)  # after start-up transients
    (w0, t0), (w1, t1) = samples[started], samples[-1]
    return (t1 - t0) / (w1 - w0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--span", type=float, default=120.0, help="simulated seconds per run")
    parser.add_argument("--world", default="outer_corridor.yaml", help="the world of the shipped bringup files")
    args = parser.parse_args()
    rows = [
        ("sim + follower", "one process", in_process(args.world, args.span, False)),
        ("sim + odometry node + follower", "one process", in_process(args.world, args.span, True)),
        ("sim + follower", "processes", across_processes("maze_sim", args.world, args.span)),
        ("sim + odometry node + follower", "processes", across_processes("maze_sim_odometry", args.world, args.span)),
    ]
    print(f"lockstep closed loop, dt = {DT} s, {args.span:.0f} s simulated on {args.world}")
    print(f"{'stack':34s} {'where':12s} {'real-time factor':>17s} {'steps/s':>9s}")
    for stack, where, factor in rows:
        print(f"{stack:34s} {where:12s} {factor:16.1f}x {factor / DT:9.0f}")


if __name__ == "__main__":
    main()
