"""The floor of rclpy's cost per callback: trivial nodes in one process, as a composed stack runs them.

    .venv/bin/python bench/bench_fleet_ros_floor.py      # 1, 10, 30, 60 nodes; each executor, each layout

K nodes, each with one subscription to /tick (and four publishers, as our nodes have a few), spun either each by an
executor on a thread of its own (`--layout threads`: amr_util.executors.NodeSpinners, how `amr-bringup --composed`
runs a stack) or all by one executor (`single`); the executor is amr_util.lean_executor.LeanExecutor (`--executor
lean`, what the suite's nodes spin on) or rclpy's SingleThreadedExecutor (`stock`). The main thread publishes /tick
at --rate Hz for --seconds. Prints the callbacks run per second, the process's CPU (cores) and the CPU per callback
(the publisher's share included). The callbacks do nothing, so the CPU per callback is what the executor and the
middleware cost for one wake-up. Each configuration runs in a process of its own. Run it under
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a ROS_DOMAIN_ID of its own.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import threading
import time


def one(nodes: int, rate: float, seconds: float, single: bool, lean: bool) -> str:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import Empty

    from amr_util.lean_executor import LeanExecutor

    make = LeanExecutor if lean else SingleThreadedExecutor

    rclpy.init()
    counts = [0] * nodes
    shared = make() if single else None
    for k in range(nodes):
        node = rclpy.create_node(f"floor_{k}")
        node.create_subscription(Empty, "/tick", lambda _, k=k: counts.__setitem__(k, counts[k] + 1), 10)
        for j in range(4):
            node.create_publisher(Empty, f"/floor_out_{k}_{j}", 10)
        if single:
            shared.add_node(node)
        else:
            executor = make()
            executor.add_node(node)
            threading.Thread(target=executor.spin, daemon=True).start()
    if single:
        threading.Thread(target=shared.spin, daemon=True).start()
    publisher = rclpy.create_node("floor_ticker").create_publisher(Empty, "/tick", 10)
    time.sleep(2.0)  # discovery
    cpu, wall, done = time.process_time(), time.monotonic(), sum(counts)
    end = wall + seconds
    while time.monotonic() < end:
        publisher.publish(Empty())
        time.sleep(1.0 / rate)
    time.sleep(0.3)
    cpu, wall, done = time.process_time() - cpu, time.monotonic() - wall, sum(counts) - done
    return (
        f"{'lean ' if lean else 'stock'} {nodes:4d} nodes, {'one executor  ' if single else 'a thread each '}: "
        f"{done / wall:6.0f} callbacks/s "
        f"(of {nodes * rate:.0f}), CPU {cpu / wall:.2f} cores, {1e6 * cpu / max(done, 1):5.0f} us CPU per callback"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", nargs="+", type=int, default=[1, 10, 30, 60])
    parser.add_argument("--rate", type=float, default=100.0, help="Hz of /tick")
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--executor", nargs="+", choices=("stock", "lean"), default=["stock", "lean"])
    parser.add_argument("--layout", nargs="+", choices=("threads", "single"), default=["threads", "single"])
    parser.add_argument("--one", nargs=3, help=argparse.SUPPRESS)  # a configuration, in the child process
    args = parser.parse_args(argv)
    if args.one:
        print(
            one(int(args.one[0]), args.rate, args.seconds, args.one[1] == "single", args.one[2] == "lean"), flush=True
        )
        os._exit(0)  # the spinning threads are daemons: no orderly shutdown needed
    from amr_util.environment import child_environment

    print(f"/tick at {args.rate:g} Hz for {args.seconds:g} s, load {os.getloadavg()[0]:.1f}")
    for executor in args.executor:
        for layout in args.layout:
            for nodes in args.nodes:
                command = [sys.executable, __file__, "--one", str(nodes), layout, executor]
                command += ["--rate", str(args.rate), "--seconds", str(args.seconds)]
                result = subprocess.run(command, env=child_environment(), capture_output=True, text=True, timeout=120)
                print(result.stdout.strip() or result.stderr[-500:], flush=True)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    raise SystemExit(main())
