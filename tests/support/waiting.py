"""Waiting in tests by looking at what is waited for, never by a fixed sleep (which is too short on a loaded machine
and too long on a quiet one)."""

from __future__ import annotations

import time
from collections.abc import Callable

POLL_PERIOD = 0.02
"""s between two looks at a condition."""


def poll_until(condition: Callable[[], bool], timeout: float, period: float = POLL_PERIOD) -> bool:
    """Look at condition() every `period` s until it holds or `timeout` s have passed; whether it held (one last
    look at the deadline). For ROS callbacks that must be spun meanwhile: support.ros.spin_until."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(period)
    return bool(condition())
