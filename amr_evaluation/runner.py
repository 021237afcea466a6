"""One runner for every sweep: episodes in a local process pool (default) or on a Dask cluster.

``run_sweep(specs, results)`` skips the specs whose key has a finished record in ``results`` (a JSON lines
file), runs the others on an executor, appends each record the moment it finishes, and returns every
spec's record in the order of ``specs``. Executors:

- ``workers=1``: in this process, one after the other, each record written as it finishes (no pool to start);
- ``workers=N``: a ``concurrent.futures.ProcessPoolExecutor`` of N processes (fork; a Ctrl-C ends a worker at
  once and quietly, its episode left for the resume; a sweep stopped early ends its workers rather than wait);
- ``scheduler="tcp://host:8786"``: ``distributed.Client(address).get_executor()``, a standard
  ``concurrent.futures.Executor`` over an existing Dask cluster. Its workers need this suite installed
  (the same version: a record depends on the code as much as on its spec).

Each episode is a pure function of its spec (amr_evaluation.episode), so the records are the same
wherever they ran, apart from their wall-clock fields. The results file is opened at the first record, after the
executor is up: a sweep that runs nothing (a scheduler that does not answer, an interrupt before any episode
finished) writes nothing.
"""

from __future__ import annotations

import gc
import os
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from amr_evaluation.episode import EpisodeSpec, run_episode
from amr_evaluation.records import RecordWriter, finished, read_records


class SweepError(RuntimeError):
    """The sweep could not run (no scheduler at that address, Dask not installed, ...)."""


@contextmanager
def executor_for(
    workers: int = 1, scheduler: str | None = None, connect_timeout: float = 10.0
) -> Iterator[Executor | None]:
    """The executor a sweep runs on (see the module docstring; None: this process); closed on exit."""
    if scheduler:
        try:
            from distributed import Client
        except ImportError as error:
            raise SweepError(
                "--scheduler needs Dask: pip install 'amr_suite[evaluation]' (dask[distributed])"
            ) from error
        try:
            client = Client(scheduler, timeout=f"{connect_timeout}s")
        except (OSError, TimeoutError, ValueError) as error:
            raise SweepError(
                f"no Dask scheduler answered at {scheduler} within {connect_timeout:g} s: {error}"
            ) from error
        try:
            with client.get_executor() as executor:
                yield executor
        finally:
            client.close()
        return
    if workers < 1:
        raise SweepError(f"workers must be at least 1, got {workers}")
    if workers == 1:
        yield None
        return
    import multiprocessing

    with ProcessPoolExecutor(
        workers, mp_context=multiprocessing.get_context("fork"), initializer=_quiet_interrupt
    ) as executor:
        try:
            yield executor
        except BaseException:  # Ctrl-C or an error: the episodes in flight are not waited for
            _terminate_workers(executor)
            raise


def _quiet_interrupt() -> None:
    """In a pool worker: Ctrl-C (SIGINT to the terminal's process group) ends it at once, without a traceback;
    the sweep's process reports the interrupt, and its episode is run again on resume. (Before this runs, the
    worker has the handler it was forked with: amr_evaluation.interrupt ends a forked process quietly too.)"""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, lambda number, frame: os._exit(128 + signal.SIGINT))


def _terminate_workers(executor: ProcessPoolExecutor) -> None:
    """End the pool's worker processes now (SIGTERM): the pool breaks, its futures fail, nothing more starts, and
    its shutdown does not wait for the episodes in flight (a SIGINT sent to the sweep's process alone)."""
    terminate = getattr(executor, "terminate_workers", None)  # Python 3.14
    if terminate is not None:
        terminate()
        return
    for process in list((getattr(executor, "_processes", None) or {}).values()):
        if process.is_alive():
            process.terminate()


class Progress:
    """tqdm's bar when tqdm is installed and the output is a terminal; else a line every few seconds."""

    def __init__(self, total: int, done: int, description: str = "episodes", stream=None) -> None:
        self.total, self.count = total, done
        self.stream = stream or sys.stderr
        self._bar = None
        self._last = 0.0
        self._began = time.monotonic()
        try:
            from tqdm import tqdm
        except ImportError:
            tqdm = None
        if tqdm is not None and self.stream.isatty():
            self._bar = tqdm(
                total=total, initial=done, desc=description, unit="ep", file=self.stream, dynamic_ncols=True
            )

    def update(self) -> None:
        self.count += 1
        if self._bar is not None:
            self._bar.update(1)
            return
        now = time.monotonic()
        if now - self._last >= 5.0 or self.count == self.total:
            self._last = now
            print(f"  {self.count}/{self.total} episodes, {now - self._began:.0f} s", file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


def run_sweep(
    specs: Sequence[EpisodeSpec],
    results: str | Path,
    *,
    workers: int = 1,
    scheduler: str | None = None,
    progress: bool = True,
    on_record: Callable[[dict[str, Any]], None] | None = None,
    episode: Callable[[dict], dict] = run_episode,
    connect_timeout: float = 10.0,
    on_start: Callable[[int, int], None] | None = None,
    stop: Callable[[], bool] | None = None,
) -> list[dict[str, Any]]:
    """Every spec's record (in the order of ``specs``), running only those without a finished one in ``results``.

    ``on_start(skipped, to_run)`` is called once the finished episodes are known (the distinct episodes with a
    finished record in ``results``, and those left to run), before any runs; ``on_record`` with each new record
    as it arrives (in completion order). ``stop()`` true (e.g. amr_evaluation.interrupt's flag) ends the sweep
    with KeyboardInterrupt: looked at before each episode run here, every 0.1 s while waiting for an executor.
    """
    results = Path(results)
    known = read_records(results)
    unique: dict[str, EpisodeSpec] = {}
    for spec in specs:
        unique.setdefault(spec.key, spec)
    todo = [spec for key, spec in unique.items() if not finished(known.get(key))]
    if on_start is not None:
        on_start(len(unique) - len(todo), len(todo))
    if todo:
        with executor_for(workers, scheduler, connect_timeout) as executor:
            bar = Progress(len(unique), len(unique) - len(todo)) if progress else None
            writer: RecordWriter | None = None
            try:
                for record in _run(executor, episode, todo, stop):
                    writer = writer or RecordWriter(results)  # opened at the first record: none, no file
                    writer.write(record)
                    known[record["key"]] = record
                    if on_record is not None:
                        on_record(record)
                    if bar is not None:
                        bar.update()
            finally:
                if writer is not None:
                    writer.close()
                if bar is not None:
                    bar.close()
    return [known[spec.key] for spec in specs]


STOP_POLL_PERIOD = 0.1
"""s between looks at ``run_sweep``'s ``stop`` while waiting for the executor."""


@contextmanager
def _forking(executor: Executor) -> Iterator[None]:
    """Around a local pool's first submits, where its workers are forked: this process's garbage collected here
    first, then the rest frozen until they are forked, so a worker never collects an object it inherited.
    A forked child has one thread and copies of everything else: collecting what this process left for the
    garbage collector (an rclpy node or context from before the sweep, say) there finalizes it against state
    that is not the child's; rclpy's did end the worker with a segmentation fault, and the pool with it.
    (gc.freeze before fork is what Python's gc documentation asks of a process that forks without exec.)"""
    if not isinstance(executor, ProcessPoolExecutor):
        yield
        return
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _run(
    executor: Executor | None,
    episode: Callable[[dict], dict],
    todo: Sequence[EpisodeSpec],
    stop: Callable[[], bool] | None = None,
) -> Iterator[dict]:
    """The records of ``todo`` as they finish: one after the other here, or as the executor completes them.
    KeyboardInterrupt as soon as ``stop()`` is seen true (before each episode here, or within STOP_POLL_PERIOD)."""

    def check() -> None:
        if stop is not None and stop():
            raise KeyboardInterrupt

    if executor is None:
        for spec in todo:
            check()
            yield episode(spec.to_dict())
        return
    futures: list[Future] = []
    try:
        check()
        with _forking(executor):
            futures = [executor.submit(episode, spec.to_dict()) for spec in todo]
        pending = set(futures)
        while pending:
            done, pending = wait(
                pending, timeout=None if stop is None else STOP_POLL_PERIOD, return_when=FIRST_COMPLETED
            )
            check()
            for future in done:
                yield future.result()
                check()
    finally:  # stopped early (an exception, Ctrl-C): what has not started is not started
        if not isinstance(executor, ProcessPoolExecutor):  # a pool's workers are ended instead (executor_for):
            for future in futures:  # a cancel racing the pool's own breakage is an InvalidStateError (3.11)
                future.cancel()


def default_workers() -> int:
    return max(1, min(2, os.cpu_count() or 1))
