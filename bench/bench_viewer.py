"""What watching costs: lockstep steps/s of a stack with 5,000 particles, without and with the viewer.

    python bench/bench_viewer.py [--steps 1500] [--runs 3] [--no-browser]

The stack: maze_localization composed in this process (map_server, simulator, wall follower, particle filter, in
the loop: each observation is answered by the wall follower once the filter's /pose for it has come). The filter
keeps 5,000 particles (min_particles = max_particles = 5000, its /particle_cloud every 0.5 s of scan time, as
shipped) and never declares itself localized, so the wall follower keeps exploring. Each run starts the stack
afresh (after one warm-up run) and times its first --steps steps (counted on /clock): the same trajectory, so the
same work, whatever the condition (the filter's cost follows the robot's motion: windows at different times of one
run are not comparable). Conditions in a rotating order, median of --runs:

  none     no viewer;
  listener the control: another process with one node taking /clock (raw), to tell the viewer's own effect
           from that of any other participant in the domain;
  viewer   the viewer as amr-bringup --view starts it (a process of its own, on /clock), no browser connected:
           it takes every topic (raw) and decodes, but draws nothing;
  browser  the same with a headless chromium (Playwright, software WebGL) showing the page: the viewer draws at
           10 Hz, 1,000 of the 5,000 particles; the browser's rendering runs on the same cores (with a GPU it would
           not).

The viewer's (and the browser's) CPU over the timed steps, s per wall s, from /proc, is printed beside. Goal: the
viewer slows the loop by at most 10 %. On a machine shared with other work the figures move with its load.
"""

from __future__ import annotations

import argparse
import os
import random
import signal
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(10, 99)))


import rclpy
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from amr_bringup.composed import composed_stack
from amr_bringup.processes import stop_processes
from amr_bringup.viewing import ViewerProcess
from amr_util.environment import child_environment
from amr_util.qos import reliable

CHROMIUM = "/usr/bin/chromium"
PARAMETERS = {
    "particle_filter.min_particles": "5000",
    "particle_filter.max_particles": "5000",
    "particle_filter.localized_confirmations": "10000",
    "simulator.lockstep_resend_period": "0.0",
}
"""5,000 particles all along, in the loop: the wall follower answers each observation once the filter's /pose for
it has come, and keeps exploring (the filter never declares itself localized)."""
LISTENER = """
import rclpy
from rclpy.executors import ExternalShutdownException
from rosgraph_msgs.msg import Clock
rclpy.init()
node = rclpy.create_node("bench_listener")
node.create_subscription(Clock, "/clock", lambda data: None, 10, raw=True)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
"""
"""The control: a process of its own with one node taking /clock, and nothing else."""
SETTLE = 4.0
"""s a viewer gets to start (imports, its web server) before the stack does."""


class StepCounter(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("bench_viewer_counter", **kwargs)
        self.steps = 0
        self.create_subscription(Clock, "/clock", self._count, reliable(100))

    def _count(self, message: Clock) -> None:
        self.steps += 1


def cpu_seconds(pid: int) -> float:
    """utime + stime of a process and its reaped children, s."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return sum(int(value) for value in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def tree_cpu_seconds(root: int) -> float:
    """CPU of a process and every descendant alive now (a browser's renderer and GPU processes)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parent = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(parent, []).append(int(entry.name))
    total, stack = 0.0, [root]
    while stack:
        pid = stack.pop()
        try:
            total += cpu_seconds(pid)
        except (OSError, IndexError, ValueError):
            pass
        stack.extend(children.get(pid, []))
    return total


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def timed_run(steps: int, condition: str) -> tuple[float, float]:
    """(steps per wall s over the first `steps` steps of a fresh stack, CPU s per wall s of the viewer (and
    browser) meanwhile) under `condition`."""
    viewer = driver = browser = listener = None
    pids: list[int] = []
    if condition == "listener":
        listener = subprocess.Popen(
            [sys.executable, "-c", LISTENER],
            env=child_environment(),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        pids.append(listener.pid)
        time.sleep(SETTLE)
    elif condition != "none":
        viewer = ViewerProcess("bench_viewer", "127.0.0.1", free_port(), True, lambda line: None)
        pids.append(viewer.process.pid)
        time.sleep(SETTLE)
        if condition == "browser":
            driver, browser = open_browser(viewer.url)
            pid = browser_pid()
            pids += [pid] if pid else []
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        counter = StepCounter(context=context)
        with composed_stack(context, "maze_localization", parameters=PARAMETERS, extra_nodes=[counter]) as (
            _,
            manager,
            _,
        ):
            if not all(step.ok for step in manager.startup()):
                raise SystemExit("maze_localization did not come up")
            while counter.steps < 1:
                time.sleep(0.001)
            cpu, started = sum(tree_cpu_seconds(p) for p in pids), time.perf_counter()
            while counter.steps < steps + 1:
                time.sleep(0.002)
            elapsed = time.perf_counter() - started
            cpu = sum(tree_cpu_seconds(p) for p in pids) - cpu
    finally:
        context.try_shutdown()
        if browser is not None:
            browser.close()
            driver.stop()
        if viewer is not None:
            stop_processes([viewer.process], 10.0, threading.Event())
        if listener is not None:
            listener.send_signal(signal.SIGINT)
            listener.wait(10.0)
    return steps / elapsed, cpu / elapsed


def open_browser(url: str):
    from playwright.sync_api import sync_playwright

    driver = sync_playwright().start()
    browser = driver.chromium.launch(
        executable_path=CHROMIUM,
        headless=True,
        args=[
            "--enable-unsafe-swiftshader",
            "--no-sandbox",
            "--disable-background-networking",
            "--disable-dev-shm-usage",
        ],
    )
    page = browser.new_page(viewport={"width": 1024, "height": 640})
    page.goto(url, timeout=120000)
    page.get_by_role("button", name="Pause", exact=True).wait_for(timeout=120000)
    return driver, browser


def parent_of(pid: int) -> int:
    try:
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return 0


def browser_pid() -> int | None:
    """The chromium main process this process started (through Playwright's driver)."""
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            command = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if not command or not command[0].endswith(b"chromium") or any(arg.startswith(b"--type=") for arg in command):
            continue
        pid = int(entry.name)
        while pid > 1:
            pid = parent_of(pid)
            if pid == os.getpid():
                return int(entry.name)
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1500, help="steps timed per run (0.05 s each)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--no-browser", action="store_true")
    args = parser.parse_args()
    conditions = ["none", "listener", "viewer"]
    if not args.no_browser and Path(CHROMIUM).exists():
        conditions.append("browser")
    elif not args.no_browser:
        print(f"no {CHROMIUM} (apt-get install chromium): measuring without a browser")
    results: dict[str, list[tuple[float, float]]] = {name: [] for name in conditions}
    timed_run(args.steps // 4, "none")  # warm-up: the filter's compiled kernels loaded, caches filled
    for run in range(args.runs):
        for name in conditions[run % len(conditions) :] + conditions[: run % len(conditions)]:
            results[name].append(timed_run(args.steps, name))
        print(
            f"run {run + 1}: " + ", ".join(f"{name} {values[-1][0]:.0f} steps/s" for name, values in results.items()),
            flush=True,
        )
    base = statistics.median(rate for rate, _ in results["none"])
    print(
        f"maze_localization composed, 5,000 particles in the loop, lockstep, first {args.steps} steps of a fresh "
        f"stack, median of {args.runs}, {os.cpu_count()} cores (load average {os.getloadavg()[0]:.1f}):"
    )
    print(f"  {'no viewer':30s} {base:7.1f} steps/s ({base * 0.05:5.1f}x real time)")
    labels = {
        "listener": "control: a /clock listener",
        "viewer": "viewer, no browser",
        "browser": "viewer + headless chromium",
    }
    for name in conditions[1:]:
        rate = statistics.median(r for r, _ in results[name])
        cpu = statistics.median(c for _, c in results[name])
        print(
            f"  {labels[name]:30s} {rate:7.1f} steps/s ({rate * 0.05:5.1f}x real time), "
            f"{100 * (rate / base - 1):+5.1f} %; its CPU {cpu:.2f} s/s"
        )


if __name__ == "__main__":
    main()
