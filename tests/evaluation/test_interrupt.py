"""Ctrl-C ends a command with one line and 130 wherever it lands: swallowed in a __del__, in a forked worker
before its own handler, twice; the runner stops on the flag, and does not wait for a pool's episodes in flight."""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import time

import pytest
from support.evaluation import tiny_specs

from amr_evaluation import interrupt, runner
from amr_evaluation.cli import main
from amr_evaluation.episode import run_episode
from amr_evaluation.interrupt import INTERRUPTED, Interrupt
from amr_evaluation.runner import run_sweep
from amr_util.environment import child_environment

LINE = "stopped: one line"
SWALLOWED = """
import os, signal, sys, time
from amr_evaluation.interrupt import Interrupt

class Swallows:
    def __del__(self):  # Ctrl-C landing in a __del__: Python prints the KeyboardInterrupt and goes on
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):  # the handler runs between two bytecodes, here
            pass

with Interrupt({line!r}, grace={grace}) as interrupt:
    Swallows()
    print("swallowed" if interrupt.is_set() else "not interrupted", flush=True)
    {then}
"""


def _script(then: str, grace: float = 0.3) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", SWALLOWED.format(line=LINE, grace=grace, then=then)],
        env=child_environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _communicate(process: subprocess.Popen) -> tuple[str, str]:
    try:
        return process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def test_an_interrupt_swallowed_by_a_del_still_ends_the_process_with_one_line():
    process = _script("time.sleep(60)  # a long episode in this process that never looks at the flag")
    began = time.monotonic()
    out, error = _communicate(process)
    assert out == "swallowed\n"
    assert process.returncode == INTERRUPTED
    assert error == LINE + "\n"  # neither "Exception ignored" nor a traceback
    assert time.monotonic() - began < 20


def test_a_second_ctrl_c_ends_the_process_at_once():
    process = _script("os.kill(os.getpid(), signal.SIGINT); time.sleep(60)", grace=60)
    out, error = _communicate(process)
    assert (out, process.returncode, error) == ("swallowed\n", INTERRUPTED, LINE + "\n")


def test_a_forked_process_without_a_handler_of_its_own_ends_quietly():
    with Interrupt(LINE):
        pid = os.fork()
        if pid == 0:  # the child: a pool worker before its initializer
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(5)
            finally:
                os._exit(3)
        _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == INTERRUPTED


def test_the_handler_and_the_unraisable_hook_are_given_back():
    handler, hook = signal.getsignal(signal.SIGINT), sys.unraisablehook
    with Interrupt(LINE):
        assert signal.getsignal(signal.SIGINT) is not handler
    assert signal.getsignal(signal.SIGINT) is handler and sys.unraisablehook is hook


@pytest.mark.parametrize("workers", [1, 2])
def test_a_set_stop_flag_ends_the_sweep_before_the_next_episode(tmp_path, workers):
    specs = tiny_specs(3, duration=1.0)
    ran = []

    def counting(spec: dict) -> dict:
        ran.append(spec)
        return run_episode(spec)

    stopped = []
    with pytest.raises(KeyboardInterrupt):
        run_sweep(
            specs,
            tmp_path / "r.jsonl",
            workers=workers,
            progress=False,
            episode=counting if workers == 1 else run_episode,  # a pool pickles its episode function
            on_record=stopped.append,
            stop=lambda: bool(stopped),
        )
    assert len(stopped) == 1
    if workers == 1:
        assert len(ran) == 1


def _slow_episode(spec: dict) -> dict:
    time.sleep(60)
    return run_episode(spec)


def test_a_stopped_pool_does_not_wait_for_the_episodes_in_flight(tmp_path):
    began = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        run_sweep(
            tiny_specs(2),
            tmp_path / "r.jsonl",
            workers=2,
            progress=False,
            episode=_slow_episode,
            stop=lambda: time.monotonic() - began > 0.5,
        )
    assert time.monotonic() - began < 20
    assert not (tmp_path / "r.jsonl").exists()


def test_the_command_interrupted_where_the_exception_is_swallowed_still_reports_it(tmp_path, monkeypatch, capsys):
    """The KeyboardInterrupt lost (as in a __del__): the flag ends the sweep after the episode, with the one line."""

    def episode(spec: dict) -> dict:
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1)  # the handler runs here
        except KeyboardInterrupt:
            pass  # swallowed
        return run_episode(spec)

    monkeypatch.setattr(interrupt, "GRACE", 600.0)  # the watchdog must not end pytest itself
    monkeypatch.setattr(runner, "run_sweep", functools.partial(run_sweep, episode=episode))
    out = tmp_path / "r.jsonl"
    code = main(
        [
            "--families",
            "open_room",
            "--size",
            "3",
            "--seeds",
            "3",
            "--duration",
            "1",
            "--workers",
            "1",
            "--out",
            str(out),
            "--no-progress",
            "--no-plots",
        ]
    )
    error = capsys.readouterr().err
    assert code == INTERRUPTED
    assert error.splitlines() == [
        f"amr-evaluate: interrupted; the finished episodes are in {out} (the same command resumes)"
    ]
    assert len(out.read_text().splitlines()) == 1
