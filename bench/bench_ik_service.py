"""/solve_ik round trip between processes over loopback DDS: latency and throughput.

    python bench/bench_ik_service.py [--requests 2000] [--seconds 5] [--clients 4]

Starts the node as `ros2 run amr_kinematics ik_service` would (lib/amr_kinematics/
ik_service, the source config/ik_chains.yaml, autostart), in a domain of its own on
loopback, then runs client processes (this script with --client):
1. one client, sequential requests: median and p99 round trip of a UR5 (6-DOF)
   position-only solve from the home pose to FK targets of random configurations,
   and of a refused request (unknown chain: transport and executors, no solve);
2. `--clients` clients at once for `--seconds`: requests per second in total.
The library solves the same targets in this process for comparison.
Targets: median <= 1 ms, >= 1,000 requests/s.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# Before rclpy is imported: DDS stays on loopback, in a domain of this run's own.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(101, 200)))

import numpy as np
import yaml

from amr_kinematics.config import load_chain_set

ROOT = Path(__file__).resolve().parents[1]

CONFIG = ROOT / "config" / "ik_chains.yaml"
EXECUTABLE = Path(sys.prefix) / "lib" / "amr_kinematics" / "ik_service"
CHAIN = "ur5"
TARGETS = 500  # distinct targets, cycled
WARMUP = 200  # requests before measuring
DISCOVERY = 30.0  # s
REPLY_TIMEOUT = 0.5  # s; a request unanswered this long is counted as lost (and not retried)
BOOTSTRAP_VARIABLES = ("LD_LIBRARY_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE")


# The node under another executor, for comparison (the executable runs MultiThreadedExecutor).
OTHER_EXECUTOR = """
import sys, rclpy
from rclpy.signals import SignalHandlerOptions
from amr_util.managed_node import spin_nodes
from amr_kinematics.ik_service_node import IKServiceNode
rclpy.init(args=sys.argv, signal_handler_options=SignalHandlerOptions.NO)
if sys.argv[1] == "single":
    from rclpy.executors import SingleThreadedExecutor as Executor
else:
    from rclpy.experimental import EventsExecutor as Executor
spin_nodes([IKServiceNode()], Executor())
"""
EXECUTORS = {
    "multi": "MultiThreadedExecutor (the ik_service executable)",
    "single": "SingleThreadedExecutor",
    "events": "rclpy.experimental.EventsExecutor",
}


def child_environment() -> dict[str, str]:
    """Our environment without the ROS wheels' bootstrap markers (as tests/conftest.py does)."""
    return {k: v for k, v in os.environ.items() if k not in BOOTSTRAP_VARIABLES}


def targets_and_home(count: int, seed: int) -> tuple[list[list[float]], list[float]]:
    """FK positions of random in-limit configurations of the chain, and its home pose."""
    config = load_chain_set(yaml.safe_load(CONFIG.read_text(encoding="utf-8")))[CHAIN]
    rng = np.random.default_rng(seed)
    chain = config.chain
    points = [chain.fk(rng.uniform(chain.lower, chain.upper)).position.tolist() for _ in range(count)]
    return points, config.home.tolist()


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q))


# --- client process -------------------------------------------------------------------------
def run_client(args) -> None:
    """Sequential requests; writes {"latencies": [s...], "successes": n} to args.out."""
    import rclpy
    from geometry_msgs.msg import Pose
    from rclpy.executors import SingleThreadedExecutor

    from amr_interfaces.srv import SolveIK

    rclpy.init()
    node = rclpy.create_node(f"bench_ik_client_{os.getpid()}")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    client = node.create_client(SolveIK, "/solve_ik")
    if not client.wait_for_service(timeout_sec=DISCOVERY):
        raise SystemExit("client: /solve_ik never appeared")
    points, home = targets_and_home(TARGETS, args.client_id)
    requests = []
    for x, y, z in points:
        target = Pose()
        target.position.x, target.position.y, target.position.z = x, y, z
        chain = "no_such_chain" if args.refused else CHAIN
        requests.append(SolveIK.Request(chain=chain, target=target, seed=home))

    lost = 0

    def call(request) -> tuple[float, bool]:
        # spin_once in a loop: spin_until_future_complete(timeout) leaks a task per call in rclpy 7.1.6
        nonlocal lost
        started = time.perf_counter()
        future = client.call_async(request)
        deadline = started + REPLY_TIMEOUT
        while not future.done() and time.perf_counter() < deadline:
            executor.spin_once(timeout_sec=0.1)
        if not future.done():
            client.remove_pending_request(future)
            lost += 1
            return time.perf_counter() - started, False
        return time.perf_counter() - started, future.result().success

    for k in range(WARMUP):
        call(requests[k % len(requests)])
    while time.time() < args.start:  # all clients begin together
        time.sleep(0.001)
    latencies, successes, k = [], 0, 0
    stop = time.time() + args.seconds if args.seconds else None
    cpu = time.process_time()
    while (k < args.requests) if stop is None else (time.time() < stop):
        latency, success = call(requests[k % len(requests)])
        latencies.append(latency)
        successes += success
        k += 1
    cpu = time.process_time() - cpu
    Path(args.out).write_text(json.dumps({"latencies": latencies, "successes": successes, "lost": lost, "cpu": cpu}))
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()


# --- coordinator ------------------------------------------------------------------------------
def start_clients(count: int, workdir: Path, *, start_in: float, **options) -> list[tuple[subprocess.Popen, Path]]:
    start = time.time() + start_in
    clients = []
    for i in range(count):
        out = workdir / f"client_{i}.json"
        command = [
            sys.executable,
            str(Path(__file__).resolve()),
            "--client",
            "--client-id",
            str(i),
            "--start",
            str(start),
            "--out",
            str(out),
        ]
        for key, value in options.items():
            if value is True:
                command.append(f"--{key}")
            elif value is not False:
                command += [f"--{key}", str(value)]
        clients.append((subprocess.Popen(command, env=child_environment()), out))
    return clients


def collect(clients, timeout: float) -> list[dict]:
    results = []
    for process, out in clients:
        if process.wait(timeout=timeout) != 0:
            raise SystemExit(f"a client failed (exit code {process.returncode})")
        results.append(json.loads(out.read_text()))
    return results


def library_times(count: int) -> tuple[list[float], float]:
    """The same solves in this process, no ROS: (times in s, success rate)."""
    config = load_chain_set(yaml.safe_load(CONFIG.read_text(encoding="utf-8")))[CHAIN]
    points, home = targets_and_home(TARGETS, 0)
    times, successes = [], 0
    for k in range(count):
        started = time.perf_counter()
        result = config.solve(points[k % len(points)], seed=home)
        times.append(time.perf_counter() - started)
        successes += result.success
    return times, successes / count


def cpu_seconds(pid: int) -> float:
    """User + system CPU time a process has used so far (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def phase(node: subprocess.Popen, clients) -> tuple[list[dict], float]:
    """The clients' results and the node's CPU seconds while they ran."""
    before = cpu_seconds(node.pid)
    results = collect(clients, 180)
    return results, cpu_seconds(node.pid) - before


def cpu_line(results: list[dict], node_cpu: float) -> str:
    count = sum(len(r["latencies"]) for r in results)
    client_cpu = sum(r["cpu"] for r in results)
    return f"  {'':<44} CPU per request: node {1e3 * node_cpu / count:.3f} ms, client {1e3 * client_cpu / count:.3f} ms"


def report(label: str, latencies: list[float]) -> None:
    ms = [1e3 * v for v in latencies]
    print(
        f"  {label:<44} median {statistics.median(ms):6.3f} ms   p99 {percentile(ms, 99):6.3f} ms   "
        f"mean {statistics.fmean(ms):6.3f} ms   ({len(ms)} requests)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--requests", type=int, default=2000, help="sequential requests of the latency runs")
    parser.add_argument("--seconds", type=float, default=5.0, help="length of the throughput run")
    parser.add_argument("--clients", type=int, default=4, help="concurrent client processes")
    parser.add_argument(
        "--executor",
        choices=sorted(EXECUTORS),
        default="multi",
        help="the node's executor: multi is the shipped node; single and events for comparison",
    )
    parser.add_argument("--client", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--client-id", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--start", type=float, default=0.0, help=argparse.SUPPRESS)
    parser.add_argument("--out", default="", help=argparse.SUPPRESS)
    parser.add_argument("--refused", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.client:
        run_client(args)
        return
    sys.stdout.reconfigure(line_buffering=True)
    if not os.access(EXECUTABLE, os.X_OK):
        raise SystemExit(f"{EXECUTABLE} is missing: run `make setup`")

    print(
        f"/solve_ik round trip, {CHAIN} position-only from home; ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}, "
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}; node: {EXECUTORS[args.executor]}"
    )
    times, rate = library_times(args.requests)
    print(
        f"  {'library solve, same targets, no ROS':<44} median {1e3 * statistics.median(times):6.3f} ms   "
        f"p99 {1e3 * percentile(times, 99):6.3f} ms   success {100 * rate:.1f} %"
    )
    ros_args = ["--ros-args", "--params-file", str(CONFIG), "-p", "autostart:=true", "--log-level", "warn"]
    command = [str(EXECUTABLE)] if args.executor == "multi" else [sys.executable, "-c", OTHER_EXECUTOR, args.executor]
    node = subprocess.Popen(command + ros_args, env=child_environment(), start_new_session=True, cwd=ROOT)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            workdir = Path(tmp)
            refused, node_cpu = phase(
                node, start_clients(1, workdir, start_in=0.0, requests=args.requests, seconds=0, refused=True)
            )
            report("refused request (transport + executors)", refused[0]["latencies"])
            print(cpu_line(refused, node_cpu))
            single, node_cpu = phase(node, start_clients(1, workdir, start_in=0.0, requests=args.requests, seconds=0))
            report("solve, 1 client", single[0]["latencies"])
            print(cpu_line(single, node_cpu))
            print(f"  {'':<44} success {100 * single[0]['successes'] / len(single[0]['latencies']):.1f} %")
            # clients start together a few seconds from now, after their imports and discovery
            loaded, node_cpu = phase(node, start_clients(args.clients, workdir, start_in=8.0, seconds=args.seconds))
            total = sum(len(r["latencies"]) for r in loaded)
            report(f"solve, {args.clients} clients at once", [v for r in loaded for v in r["latencies"]])
            print(cpu_line(loaded, node_cpu) + " (node CPU includes the clients' start-up wait)")
            # Fast DDS loses a reply now and then when several clients hammer one service
            # (ros2/rcl#1163, ros2/rmw#372): counted, and left out of the throughput
            lost = sum(r["lost"] for r in loaded)
            print(
                f"  throughput with {args.clients} clients: {(total - lost) / args.seconds:7.0f} replies/s "
                f"(success {100 * sum(r['successes'] for r in loaded) / total:.1f} %, "
                f"{lost} requests never answered within {REPLY_TIMEOUT} s)"
            )
    finally:
        node.send_signal(2)  # SIGINT: the node deactivates, cleans up and exits
        try:
            node.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(node.pid, 9)


if __name__ == "__main__":
    main()
