"""Service requests in flight from the viewer: each answered through its callback, or told it timed out. No rclpy:
a request is any future with done(), result(), exception() and cancel() (rclpy's Future is one)."""

from __future__ import annotations

import time
from collections.abc import Callable

ANSWER_TIMEOUT = 5.0
"""s a service has to answer a request from the page."""


class Pending:
    """Requests waiting for their answer; `poll` hands each answer (an exception too) or its timeout on."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._waiting: list[tuple[object, float, Callable, Callable[[], None]]] = []

    def __len__(self) -> int:
        return len(self._waiting)

    def add(self, future, on_answer: Callable, on_timeout: Callable[[], None], timeout: float = ANSWER_TIMEOUT):
        self._waiting.append((future, self._clock() + timeout, on_answer, on_timeout))

    def poll(self) -> None:
        now, still = self._clock(), []
        for future, deadline, on_answer, on_timeout in self._waiting:
            if future.done():
                on_answer(future.exception() or future.result())
            elif now > deadline:
                future.cancel()
                on_timeout()
            else:
                still.append((future, deadline, on_answer, on_timeout))
        self._waiting = still
