"""The ROS side of the tests: DDS domains of their own, spinning until something holds, node processes.

conftest.py builds its fixtures (ros_domain, ros_context, executor, node_process) on these; a test module imports
them from here.
"""

from __future__ import annotations

import itertools
import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from amr_util.environment import child_environment

ROOT = Path(__file__).resolve().parents[2]
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


def close(executor) -> None:
    """Destroy the executor's nodes: an undestroyed node outlives its test in the ROS graph, where a
    later test (or a node process) can find a stale namesake."""
    nodes = executor.get_nodes()
    executor.shutdown()
    for node in nodes:
        node.destroy_node()


def spin_until(executor, condition: Callable[[], bool], timeout: float) -> bool:
    """Spin until condition() holds or the timeout passes; returns whether it held."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        executor.spin_once(timeout_sec=0.02)
    return condition()


def spin_for(executor, seconds: float) -> None:
    """Spin for `seconds` whatever happens: only to show that something does NOT come (an extra message, a step
    that should not be taken); to wait for something that does come, spin_until it."""
    spin_until(executor, lambda: False, seconds)


def published_topics(node, name: str, namespace: str, expected=(), timeout: float = 30.0) -> dict[str, str]:
    """The topics node `namespace/name` publishes, by the ROS graph as `node` sees it: {topic: first type}.

    The graph is eventually consistent: a node's own new publishers reach its graph cache through discovery, so
    under load the first look can miss them (a full suite on 2 cores once listed none of 8 within 10 s). This waits
    (without spinning: the graph updates on DDS threads) until every `expected` topic is listed or the timeout
    passes, and returns what is listed then."""
    deadline = time.monotonic() + timeout
    while True:
        listed = {topic: types[0] for topic, types in node.get_publisher_names_and_types_by_node(name, namespace)}
        if set(expected) <= set(listed) or time.monotonic() >= deadline:
            return listed
        time.sleep(0.05)


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
