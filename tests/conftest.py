"""Test harness: DDS kept on loopback in a domain of this run's own, rclpy contexts, node processes."""

from __future__ import annotations

import itertools
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

# Before rclpy is imported anywhere: no DDS traffic leaves loopback, and parallel runs do not meet.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(10, 100)))  # tests: ros_domain

import pytest  # noqa: E402
import rclpy  # noqa: E402
from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor  # noqa: E402

from amr_util.environment import child_environment  # noqa: E402,F401 (tests import it from here)

ROOT = Path(__file__).resolve().parent.parent
PREFIX = Path(sys.prefix)


def _test_domains() -> tuple[int, int]:
    """(first, count) of the DDS domains the tests take one by one: 101-232, or AMR_TEST_DOMAINS=<first>-<last>
    (runs side by side on one machine each give their own range)."""
    text = os.environ.get("AMR_TEST_DOMAINS", "101-232")
    try:
        first, last = (int(part) for part in text.split("-"))
    except ValueError:
        raise pytest.UsageError(f"AMR_TEST_DOMAINS={text!r}: expected <first>-<last>, e.g. 101-232") from None
    if not 0 <= first <= last <= 232:
        raise pytest.UsageError(f"AMR_TEST_DOMAINS={text!r}: a DDS domain is 0-232, first <= last")
    return first, last - first + 1


def _worker_domains(first: int, count: int) -> tuple[int, int]:
    """Under pytest-xdist (`pytest -n N`): worker i of N takes the i-th part of the range, and its first domain
    becomes its ROS_DOMAIN_ID (the tests without a domain of their own), so the workers never meet."""
    worker, workers = os.environ.get("PYTEST_XDIST_WORKER"), os.environ.get("PYTEST_XDIST_WORKER_COUNT")
    if not worker or not workers:
        return first, count
    index, workers = int(worker.removeprefix("gw")), int(workers)
    share = count // workers
    if share < 2:
        raise pytest.UsageError(f"{count} test domains cannot be shared by {workers} workers (2 each at least)")
    first += index * share
    os.environ["ROS_DOMAIN_ID"] = str(first)
    return first + 1, share - 1


FIRST_TEST_DOMAIN, TEST_DOMAINS = _worker_domains(*_test_domains())
_next_domain = itertools.count(random.SystemRandom().randrange(TEST_DOMAINS))


def fresh_domain() -> int:
    """The next DDS domain of the tests' range (101-232, or AMR_TEST_DOMAINS), round robin."""
    return FIRST_TEST_DOMAIN + next(_next_domain) % TEST_DOMAINS


@pytest.fixture
def ros_domain(monkeypatch) -> int:
    """A DDS domain (fresh_domain) of this test's own, also for the processes it starts.

    DDS announces the participants of earlier tests until their lease runs out (about 20 s); in a
    shared domain their ghost services shadow live namesakes and requests go unanswered.
    """
    domain = fresh_domain()
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    return domain


@pytest.fixture
def ros_context(ros_domain):
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain)
    yield context
    context.try_shutdown()


def close(executor) -> None:
    """Destroy the executor's nodes: an undestroyed node outlives its test in the ROS graph, where a
    later test (or a node process) can find a stale namesake."""
    nodes = executor.get_nodes()
    executor.shutdown()
    for node in nodes:
        node.destroy_node()


@pytest.fixture
def executor(ros_context):
    executor = SingleThreadedExecutor(context=ros_context)
    yield executor
    close(executor)


@pytest.fixture
def multi_executor(ros_context):
    executor = MultiThreadedExecutor(num_threads=4, context=ros_context)
    yield executor
    close(executor)


def spin_until(executor, condition, timeout: float) -> bool:
    """Spin until condition() holds or the timeout passes; returns whether it held."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        executor.spin_once(timeout_sec=0.02)
    return condition()


class NodeProcess:
    """A node executable run as `ros2 run` would: lib/<package>/<executable> under the venv prefix."""

    def __init__(self, package: str, executable: str, *ros_args: str, prefix: Path = PREFIX) -> None:
        path = prefix / "lib" / package / executable
        if not os.access(path, os.X_OK):
            raise FileNotFoundError(f"{path} is missing or not executable: run `make setup`")
        command = [str(path)] + (["--ros-args", *ros_args] if ros_args else [])
        self.process = subprocess.Popen(
            command,
            env=child_environment(),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,
        )

    def stop(self, timeout: float = 10.0) -> tuple[int, str]:
        """SIGINT, then SIGKILL if it lingers; returns (exit code, output)."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        try:
            output, _ = self.process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            output, _ = self.process.communicate()
        return self.process.returncode, output


@pytest.fixture
def node_process(ros_domain):
    started: list[NodeProcess] = []

    def start(package: str, executable: str, *ros_args: str) -> NodeProcess:
        process = NodeProcess(package, executable, *ros_args)
        started.append(process)
        return process

    yield start
    for process in started:
        process.stop()
