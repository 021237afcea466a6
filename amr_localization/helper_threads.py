"""The particle filter's helper threads: a few long-lived workers that run work beside the update's own thread.

The filter runs work on a second core while its update goes on: the places' fits, `elsewhere`'s background, the place
search's next nodes, half of a large likelihood sum (particle_filter, likelihood_field), about eight tasks an update,
on long-lived threads (a thread started per task costs a stack and an allocator arena each time; the decision
record's seventeenth pass measured it). A task never waits for another task,
so a few workers serve any number of filters in one process (tasks queue, none blocks another for good).

`submit(function, *args)` returns a concurrent.futures.Future: `result()` waits for it and raises its exception there.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import Future, ThreadPoolExecutor

WORKERS = 8
"""threads at most: a filter runs up to four tasks at once (the scan-matched odometry or the fits and the background,
the search's nodes, half a sum); twice that, so that two filters in one process (a fleet's) do not queue."""

_lock = threading.Lock()
_pool: ThreadPoolExecutor | None = None
_pid = 0


def submit(function, *args) -> Future:
    """Run function(*args) on a helper thread; its Future. A process forked from one that had workers makes its own
    (a forked child inherits the pool but not its threads)."""
    global _pool, _pid
    with _lock:
        if _pool is None or _pid != os.getpid():
            _pool = ThreadPoolExecutor(WORKERS, thread_name_prefix="amr_localization helper")
            _pid = os.getpid()
        pool = _pool
    return pool.submit(function, *args)
