"""Ctrl-C and SIGTERM as flags that a signal handler can set safely.

A Python signal handler runs in the main thread between two bytecodes, and that can be
inside `threading.Event.wait()` while the event's internal lock is held: an `Event.set()`
from the handler then waits forever for the lock its own thread holds. On CI this left
amr-bringup deaf to SIGTERM. These flags are plain attributes: setting one takes no lock,
and reading one from any thread sees the value (the GIL orders the writes).
"""

from __future__ import annotations

import signal
import time

POLL_PERIOD = 0.02  # s between looks at a flag while waiting for it


class Flag:
    """Set once, never cleared; `is_set()` as threading.Event has it, without its lock."""

    def __init__(self) -> None:
        self._set = False

    def set(self) -> None:
        self._set = True

    def is_set(self) -> bool:
        return self._set

    def wait(self, timeout: float) -> bool:
        """Sleep until the flag is set or `timeout` s have passed; returns the flag."""
        deadline = time.monotonic() + timeout
        while not self._set:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                break
            time.sleep(min(POLL_PERIOD, remaining))
        return self._set


class StopSignals:
    """SIGINT/SIGTERM: the first sets `stop` (a clean stop), the next one `hurry` (stop now).

    Construct it in the main thread (Python installs signal handlers only there).
    """

    def __init__(self) -> None:
        self.stop, self.hurry = Flag(), Flag()
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, self._on_signal)

    def _on_signal(self, signum, frame) -> None:
        (self.hurry if self.stop.is_set() else self.stop).set()
