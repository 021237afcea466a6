"""Recording cost: rosbags (rosbag2 + MCAP storage) against plain mcap, per message, next to a sim step.

    python bench/bench_record.py [--steps 3000] [--loop-seconds 60] [--runs 3]

Each simulated step of a lockstep stack publishes about five messages (scan, odometry, status,
cmd_vel, tf). Both writers get the same rclpy-serialized CDR bytes (a recorder subscribes with
raw=True), so the figures are the libraries' own cost per message, median of 5 runs. mcap alone
writes no metadata.yaml (`ros2 bag info` needs it), so it is the floor, not a candidate.
Then the library cost is put against one Simulator.step (no ROS), and the goal is measured where it
applies: the ROS lockstep loop (maze_sim composed in one process: map_server, simulator, wall
follower, on /clock) for --loop-seconds simulated seconds, without recording, with the recorder
as a process of its own recording every topic (what `amr-bringup maze_sim --composed --record`
does), and with the recorder node in the stack's process (what the demo does); median wall time of
--runs each, interleaved. Goal: recording slows the loop by at most 20 %.
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(10, 99)))


import rclpy
from mcap.writer import Writer as McapWriter
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan

from amr_bringup.bag_writer import BagWriter, suite_typestore
from amr_bringup.composed import composed_stack
from amr_bringup.processes import stop_processes
from amr_bringup.recorder import BackgroundSpin, Recorder
from amr_bringup.recording import RecorderProcess
from amr_maps.world import load_world, resolve_world_path
from amr_simulation.simulator import Simulator

MESSAGES_PER_STEP = 5


def samples():
    scan = LaserScan(ranges=[1.5] * 240, intensities=[])
    scan.header.frame_id = "base_scan"
    odom = Odometry(child_frame_id="base_footprint")
    odom.header.frame_id = "odom"
    return {
        "/scan": ("sensor_msgs/msg/LaserScan", serialize_message(scan)),
        "/odom": ("nav_msgs/msg/Odometry", serialize_message(odom)),
    }


def with_rosbags(directory: Path, steps: int, messages) -> float:
    with BagWriter(directory / "rosbags.mcap") as writer:
        for topic, (msgtype, _) in messages.items():
            writer.add_topic(topic, msgtype)
        started = time.perf_counter()
        for step in range(steps):
            for topic, (_, data) in messages.items():
                writer.write(topic, step * 50_000_000, data)
        elapsed = time.perf_counter() - started
    return elapsed / (steps * len(messages))


def with_mcap(directory: Path, steps: int, messages) -> float:
    store = suite_typestore()
    with open(directory / "plain.mcap", "wb") as stream:
        writer = McapWriter(stream)
        writer.start(profile="ros2", library="bench")
        channels = {}
        for topic, (msgtype, _) in messages.items():
            text, _ = store.generate_msgdef(msgtype, ros_version=2)
            schema = writer.register_schema(msgtype, "ros2msg", text.encode())
            channels[topic] = writer.register_channel(topic, "cdr", schema)
        started = time.perf_counter()
        for step in range(steps):
            for topic, (_, data) in messages.items():
                writer.add_message(channels[topic], step * 50_000_000, data, step * 50_000_000)
        elapsed = time.perf_counter() - started
        writer.finish()
    return elapsed / (steps * len(messages))


def sim_step_cost(steps: int) -> float:
    simulator = Simulator(load_world(resolve_world_path("inner_maze.yaml")))
    started = time.perf_counter()
    for _ in range(steps):
        simulator.step(0.1, 0.3)
    return (time.perf_counter() - started) / steps


class StepCounter(Node):
    """Counts /clock: one per lockstep observation."""

    def __init__(self, **kwargs) -> None:
        super().__init__("bench_step_counter", **kwargs)
        self.steps = 0
        self.create_subscription(Clock, "/clock", self._count, 10)

    def _count(self, message: Clock) -> None:
        self.steps += 1


def lockstep_loop(seconds: float, record_to: Path | None, in_process: bool = False) -> float:
    """Wall-clock seconds of `seconds` simulated seconds of maze_sim (composed), optionally recorded by a recorder
    process or (in_process) by a recorder node in this process."""
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        counter = StepCounter(context=context)
        extra: list[Node] = [counter]
        recording = process = recorder = None
        if record_to is not None and not in_process:
            process = RecorderProcess("bench_recorder", str(record_to), [], True, counter, lambda line: None)
        elif record_to is not None:
            recorder = Recorder(
                context=context,
                parameter_overrides=[Parameter("path", value=str(record_to)), Parameter("use_sim_time", value=True)],
            )
            recording = BackgroundSpin(recorder)  # as amr-bringup does: the recorder has an executor of its own
        waited = process if process is not None else recorder

        def hook(node) -> None:
            if waited is not None:
                waited.wait_until_caught_up()

        wanted = round(seconds / 0.05) + 1
        with composed_stack(
            context,
            "maze_sim",
            parameters={"simulator.lockstep_resend_period": "0.0"},
            extra_nodes=extra,
            before_activate=hook,
        ) as (_, manager, _):
            if not all(step.ok for step in manager.startup()):
                raise RuntimeError("maze_sim did not come up")
            started = time.perf_counter()
            while counter.steps < wanted:
                time.sleep(0.005)
            elapsed = time.perf_counter() - started
        if recording is not None:
            recording.stop()
        if process is not None:
            stop_processes([process.process], 10.0, threading.Event())
            process.process.close()
    finally:
        context.try_shutdown()
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--loop-seconds", type=float, default=60.0, help="simulated s of the ROS loop per run")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    messages = samples()
    results = {"rosbags (rosbag2 MCAP + metadata.yaml)": [], "mcap (.mcap only)": []}
    for _ in range(5):
        with tempfile.TemporaryDirectory() as directory:
            results["rosbags (rosbag2 MCAP + metadata.yaml)"].append(
                with_rosbags(Path(directory), args.steps, messages)
            )
            results["mcap (.mcap only)"].append(with_mcap(Path(directory), args.steps, messages))
    print(f"write cost per message ({args.steps * len(messages)} messages: LaserScan 240 beams + Odometry)")
    for name, values in results.items():
        print(f"  {name:40s} {statistics.median(values) * 1e6:6.1f} us")
    step = sim_step_cost(args.steps)
    rosbags = statistics.median(results["rosbags (rosbag2 MCAP + metadata.yaml)"])
    print(
        f"Simulator.step (inner_maze, numpy LiDAR, no ROS): {step * 1e6:.0f} us;"
        f" {MESSAGES_PER_STEP} messages recorded with rosbags: {MESSAGES_PER_STEP * rosbags * 1e6:.0f} us"
        f" ({100 * MESSAGES_PER_STEP * rosbags / step:.0f} % of a bare step)"
    )
    plain, separate, inside = [], [], []
    with tempfile.TemporaryDirectory() as directory:
        for run in range(args.runs):
            plain.append(lockstep_loop(args.loop_seconds, None))
            separate.append(lockstep_loop(args.loop_seconds, Path(directory) / f"process{run}.mcap"))
            inside.append(lockstep_loop(args.loop_seconds, Path(directory) / f"node{run}.mcap", in_process=True))
    base = statistics.median(plain)
    print(f"ROS lockstep loop, maze_sim composed, {args.loop_seconds:.0f} simulated s (median of {args.runs}):")
    print(f"  without recording                  {base:6.2f} s wall ({args.loop_seconds / base:5.1f}x real time)")
    for name, runs in (("recorder process (amr-bringup)", separate), ("recorder node in the process", inside)):
        rec = statistics.median(runs)
        print(
            f"  {name:34s} {rec:6.2f} s wall ({args.loop_seconds / rec:5.1f}x real time), "
            f"{100 * (rec / base - 1):+.1f} % (goal <= +20 %)"
        )


if __name__ == "__main__":
    main()
