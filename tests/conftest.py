"""Test harness: DDS kept on loopback in a domain of this run's own, rclpy contexts, node processes.

A test module imports the package under test, tests/support and nothing else of tests/: the fixtures of this file
and of the support modules named in pytest_plugins reach it by name (a fixture imported into a test module would
shadow them). Helpers that are not fixtures (spin_until, fresh_domain, NodeProcess, ...) are in support.ros.
"""

from __future__ import annotations

import os
import random
import resource
import shutil
import signal
import tempfile
import time
from pathlib import Path

import pytest
import rclpy
from hypothesis import settings
from rclpy.executors import MultiThreadedExecutor
from support.ros import NodeProcess, close, fresh_domain, spin_until
from support.schedule import calls_no_kernel, longest_files_first

from amr_util.lean_executor import LeanExecutor

pytest_plugins = ["support.kinematics", "support.ik_service", "support.simulator_probe"]
"""Fixtures of a directory's tests: the kinematics chains, the IK service launcher, the simulator node probe."""

__all__ = ["spin_until"]
"""tests/mapping still imports spin_until from here (support.ros has it)."""

# Before any ROS context is made (rcl reads them at rclpy.init): no DDS traffic leaves loopback, and parallel runs
# do not meet (support.ros has given each pytest-xdist worker a domain of its own).
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(10, 100)))  # tests: ros_domain

# Hypothesis without its 200 ms deadline per example: a wall-clock limit fails a sound test on a loaded 2-core machine
# (a first example that compiles a numba kernel took 426 ms beside other runs); what a test checks is its assertions.
settings.register_profile("suite", deadline=None)
settings.load_profile("suite")

# A run started with SIGINT ignored (a background job of a non-interactive shell: `nohup make test &`) hands that on
# to every process the tests start, and the tests that interrupt one (Ctrl-C of a sweep, a stack's duration) wait in
# vain: SIGINT handled here, so the processes started from here begin with its default again.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


WARMED = "AMR_TEST_NUMBA_WARMED"
"""Set by a parallel run's controller for its workers: the file support.numba_cache.Warming writes once the numba
kernels are compiled."""
_WARMING = pytest.StashKey[tuple]()
"""The controller's warm-up (support.numba_cache.Warming) and when it began."""


def _log(line: str) -> None:
    if CPU_LOG:
        with open(CPU_LOG, "a", encoding="utf-8") as log:
            log.write(line + "\n")


def pytest_sessionstart(session) -> None:
    """A parallel run (pytest-xdist's controller, before its workers start: their hook runs after this one) has the
    numba kernels compiled once (support.numba_cache), not by every worker and node process side by side: started
    here and not waited for, the workers start, collect and run the tests that call no kernel meanwhile."""
    config = session.config
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    from support.numba_cache import Warming

    done = Path(tempfile.mkdtemp(prefix="amr-numba-warm-")) / "done"
    os.environ[WARMED] = str(done)  # before the workers start: they inherit it
    began = time.time()
    config.stash[_WARMING] = (Warming(done), began)


def pytest_terminal_summary(terminalreporter, config) -> None:
    """The controller's line on the numba warm-up (when it ended, in AMR_TEST_CPU's record)."""
    if _WARMING not in config.stash:
        return
    warming, began = config.stash[_WARMING]
    warming.stop()
    terminalreporter.write_line(warming.line(timeout=5.0))
    if warming.done.is_file():
        _log(f"# warm-up {began:.2f} {warming.done.stat().st_mtime:.2f}")
    shutil.rmtree(warming.done.parent, ignore_errors=True)


def _wait_for_kernels(item) -> None:
    """A worker's test that calls numba kernels waits for the controller's warm-up (pytest_sessionstart)."""
    done = os.environ.get(WARMED)
    if not done or Path(done).is_file() or calls_no_kernel(item):
        return
    from support.numba_cache import wait_for

    began = time.time()
    wait_for(Path(done))
    _log(f"# waited {os.environ.get('PYTEST_XDIST_WORKER')} {began:.2f} {time.time():.2f}")


def pytest_collection_modifyitems(config, items) -> None:
    """A pytest-xdist worker collects the files longest first (support.schedule): with `--dist loadfile
    --no-loadscope-reorder` (make test) the files are handed out in that order and the workers finish together."""
    if hasattr(config, "workerinput"):
        items[:] = longest_files_first(items)
        _log(f"# collected {os.environ.get('PYTEST_XDIST_WORKER')} {time.time():.2f}")


CPU_LOG = os.environ.get("AMR_TEST_CPU")
"""A file each test's CPU seconds are appended to (`AMR_TEST_CPU=cpu.txt`): this process's and its ended children's
(a stack's processes, chromium at its module's end), from its setup to its teardown, module fixtures' included. Lines
like `--durations=0`'s: `python -m support.schedule cpu.txt` (from tests/) sums them per file."""


def _cpu_seconds() -> float:
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _wait_for_kernels(item)
    if not CPU_LOG:
        return (yield)
    start, began = _cpu_seconds(), time.time()
    try:
        return (yield)
    finally:
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        _log(f"{_cpu_seconds() - start:.2f}s cpu {item.nodeid} {worker} {began:.2f} {time.time():.2f}")


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


@pytest.fixture
def executor(ros_context):
    """The executor the product spins a node on (amr_util.executors): rclpy's SingleThreadedExecutor's behaviour at
    half its CPU per callback."""
    executor = LeanExecutor(context=ros_context)
    yield executor
    close(executor)


@pytest.fixture
def multi_executor(ros_context):
    executor = MultiThreadedExecutor(num_threads=4, context=ros_context)
    yield executor
    close(executor)


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
