"""Throttled log calls that cost next to nothing while they are throttled.

rclpy 7.1.6's `logger.warning(text, throttle_duration_sec=p)` resolves its caller (`inspect.getframeinfo`,
`os.path.realpath`) at every call, before its throttle drops the message: a warning a node repeats every step
costs tens of microseconds each time, most of them for nothing (the path follower's warnings were
8-19 % of the 20-robot fleet's busy samples). `ThrottledLogger` decides first, as rclpy's throttle does (one
message per call site per `period` s of wall-clock time, the first one logged), and calls the logger only for a
message that goes out.

    from amr_util.throttle import ThrottledLogger

    self._throttled = ThrottledLogger(self.get_logger, period=2.0)  # the node's logger, asked when a message goes out
    self._throttled.warning("a message with a negative stamp was dropped")  # at most once per 2 s from this line
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Hashable


class Throttle:
    """True at most once per `period` s of `clock` for each key (the first call of a key: True)."""

    def __init__(self, period: float, clock: Callable[[], float] = time.monotonic) -> None:
        if not period >= 0.0:
            raise ValueError(f"throttle period {period!r} is not a number of seconds >= 0")
        self.period = float(period)
        self._clock = clock
        self._last: dict[Hashable, float] = {}

    def __call__(self, key: Hashable = None) -> bool:
        now = self._clock()
        last = self._last.get(key)
        if last is not None and now - last < self.period:
            return False
        self._last[key] = now
        return True


class ThrottledLogger:
    """The logger's debug, info, warning and error, each call site (the caller's code and line) throttled to one
    message per `period` s; each returns whether the message went out. `get_logger` gives the logger when a
    message goes out (a node's `get_logger`)."""

    def __init__(self, get_logger: Callable[[], object], period: float, clock: Callable[[], float] = time.monotonic):
        self.get_logger = get_logger
        self._throttle = Throttle(period, clock)

    def debug(self, text: str) -> bool:
        return self._log("debug", text)

    def info(self, text: str) -> bool:
        return self._log("info", text)

    def warning(self, text: str) -> bool:
        return self._log("warning", text)

    def error(self, text: str) -> bool:
        return self._log("error", text)

    def _log(self, severity: str, text: str) -> bool:
        caller = sys._getframe(2)  # the caller of debug/info/warning/error
        if not self._throttle((caller.f_code, caller.f_lineno)):
            return False
        # one line per severity: rclpy's logger keeps one severity per line that calls it (another raises
        # "Logger severity cannot be changed between calls")
        logger = self.get_logger()
        if severity == "debug":
            logger.debug(text)
        elif severity == "info":
            logger.info(text)
        elif severity == "warning":
            logger.warning(text)
        else:
            logger.error(text)
        return True
