"""The runner: local pools and a loopback Dask cluster give the same records; a killed sweep resumes."""

from __future__ import annotations

import gc
import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from support.evaluation import tiny_specs
from support.waiting import poll_until

from amr_evaluation.episode import run_episode
from amr_evaluation.records import RecordWriter, finished, read_records, without_timing
from amr_evaluation.runner import SweepError, run_sweep
from amr_util.environment import child_environment

TESTS = Path(__file__).resolve().parents[1]
VENV_BIN = Path(sys.executable).parent


def test_records_come_back_in_spec_order_and_a_second_run_redoes_nothing(tmp_path):
    specs = tiny_specs(3, duration=1.0)
    results = tmp_path / "r.jsonl"
    ran = []

    def counting(spec: dict) -> dict:
        ran.append(spec)
        return run_episode(spec)

    records = run_sweep(specs, results, progress=False, episode=counting)
    assert [r["key"] for r in records] == [s.key for s in specs] and len(ran) == 3
    again = run_sweep(specs + specs[:1], results, progress=False, episode=counting)
    assert len(ran) == 3, "finished episodes ran again"
    assert [r["key"] for r in again] == [s.key for s in specs + specs[:1]]
    assert len(results.read_text().splitlines()) == 3


def test_an_errored_record_is_run_again_and_a_cut_line_is_skipped(tmp_path):
    specs = tiny_specs(2, duration=1.0)
    results = tmp_path / "r.jsonl"
    with RecordWriter(results) as writer:
        writer.write({**run_episode(specs[0]), "error": "RuntimeError: the machine rebooted"})
    with results.open("a") as stream:
        stream.write('{"key": "cut sh')  # what a kill in the middle of a write leaves
    assert set(read_records(results)) == {specs[0].key}
    records = run_sweep(specs, results, progress=False)
    assert all(r["error"] is None for r in records)
    assert set(read_records(results)) == {s.key for s in specs}
    lines = results.read_text().splitlines()
    assert lines[1] == '{"key": "cut sh' and len(lines) == 4  # the cut line was left alone, on its own line


def test_two_local_workers_give_the_records_of_one(tmp_path):
    specs = tiny_specs(4, duration=2.0)
    one = run_sweep(specs, tmp_path / "one.jsonl", workers=1, progress=False)
    two = run_sweep(specs, tmp_path / "two.jsonl", workers=2, progress=False)
    assert [without_timing(r) for r in one] == [without_timing(r) for r in two]


class _Cycle:
    """An object in a reference cycle: only the garbage collector frees it."""


def test_a_local_pool_forked_from_a_process_with_ros_garbage_gives_every_record(tmp_path, ros_domain, request):
    """rclpy nodes and contexts left to the garbage collector before the sweep (a notebook's, a test worker's):
    a forked worker that collected them died of a segmentation fault and broke the pool."""
    import rclpy
    from std_msgs.msg import String

    thresholds = gc.get_threshold()
    gc.set_threshold(50_000, 10, 10)  # no collection here before the fork; the worker's episode reaches one
    request.addfinalizer(lambda: gc.set_threshold(*thresholds))
    for index in range(5):
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=ros_domain)
        node = rclpy.create_node(f"left_behind_{index}", context=context)
        node.create_publisher(String, "left_behind", 10)
        cycle = _Cycle()
        cycle.self, cycle.node, cycle.context = cycle, node, context
        del node, context, cycle
    records = run_sweep(tiny_specs(6, duration=2.0), tmp_path / "r.jsonl", workers=2, progress=False)
    assert len(records) == 6 and all(finished(record) for record in records), records


def test_a_killed_sweep_resumes_without_redoing_finished_episodes(tmp_path):
    specs = tiny_specs(8, duration=4.0)
    results = tmp_path / "killed.jsonl"
    script = (
        "import sys, time; from support.evaluation import tiny_specs; from amr_evaluation.runner import run_sweep; "
        "from amr_evaluation.episode import run_episode; "
        "slow = lambda spec: (run_episode(spec), time.sleep(0.3))[0]; "  # a window to kill it in, on any load
        "run_sweep(tiny_specs(8, duration=4.0), sys.argv[1], workers=1, progress=False, episode=slow)"
    )
    env = child_environment(PYTHONPATH=os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")]))
    process = subprocess.Popen([sys.executable, "-c", script, str(results)], env=env)
    try:
        poll_until(
            lambda: process.poll() is not None or (results.exists() and len(results.read_text().splitlines()) >= 2),
            60.0,
        )
        assert process.poll() is None, "the sweep ended before it could be killed"
        process.send_signal(signal.SIGKILL)
    finally:
        process.wait()
    finished = read_records(results)
    assert 2 <= len(finished) < len(specs)
    ran = []

    def counting(spec: dict) -> dict:
        ran.append(spec)
        return run_episode(spec)

    records = run_sweep(specs, results, progress=False, episode=counting)
    assert not {_key(spec) for spec in ran} & set(finished)
    assert len(ran) == len(specs) - len(finished)
    assert all(r["error"] is None for r in records)
    for record in records:  # the finished ones are the very records written before the kill
        if record["key"] in finished:
            assert record == finished[record["key"]]


def _key(spec: dict) -> str:
    from amr_evaluation.episode import EpisodeSpec

    return EpisodeSpec.from_dict(spec).key


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture
def dask_cluster(tmp_path):
    """A loopback Dask scheduler and one worker process with two single-threaded worker processes."""
    pytest.importorskip("distributed")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = child_environment(DASK_DISTRIBUTED__WORKER__DAEMON="False")
    logs = (tmp_path / "dask.log").open("w")
    scheduler = subprocess.Popen(
        [
            str(VENV_BIN / "dask"),
            "scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            str(port),
            "--no-dashboard",
            "--no-show",
        ],
        env=env,
        stdout=logs,
        stderr=subprocess.STDOUT,
        cwd=tmp_path,
        start_new_session=True,
    )
    workers = subprocess.Popen(
        [
            str(VENV_BIN / "dask"),
            "worker",
            address,
            "--nworkers",
            "2",
            "--nthreads",
            "1",
            "--host",
            "127.0.0.1",
            "--no-dashboard",
            "--local-directory",
            str(tmp_path),
        ],
        env=env,
        stdout=logs,
        stderr=subprocess.STDOUT,
        cwd=tmp_path,
        start_new_session=True,
    )
    try:
        from distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for process in (workers, scheduler):
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGTERM)
        for process in (workers, scheduler):
            try:
                process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
        logs.close()


def test_a_loopback_dask_cluster_gives_the_local_records(tmp_path, dask_cluster):
    specs = tiny_specs(4, duration=2.0)
    remote = run_sweep(specs, tmp_path / "dask.jsonl", scheduler=dask_cluster, progress=False)
    local = run_sweep(specs, tmp_path / "local.jsonl", workers=1, progress=False)
    assert all(r["error"] is None for r in remote)
    assert [without_timing(r) for r in remote] == [without_timing(r) for r in local]
    assert json.loads((tmp_path / "dask.jsonl").read_text().splitlines()[0])["key"] in {s.key for s in specs}


def test_no_scheduler_at_the_address_is_a_clear_error(tmp_path):
    pytest.importorskip("distributed")
    with pytest.raises(SweepError, match="no Dask scheduler answered at tcp://127.0.0.1:"):
        run_sweep(
            tiny_specs(1),
            tmp_path / "r.jsonl",
            scheduler=f"tcp://127.0.0.1:{_free_port()}",
            progress=False,
            connect_timeout=1.0,
        )
