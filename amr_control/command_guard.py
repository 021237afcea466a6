"""The last word before a command leaves the node: stale data stops the robot, the sign is the robot's.

Kept out of the controller because both rules are about the link to the robot,
not about wall following: the watchdog runs on the node's clock (arrival
times, not header stamps, which may come from another machine's clock), and
the sign flip is what seed 002 section 5.2.1 found on its real TurtleBot3.
"""

from __future__ import annotations

import math


class CommandGuardError(ValueError):
    """An invalid watchdog timeout."""


class FreshnessWatchdog:
    """Says when the last synchronized (odometry, scan) pair is older than ``timeout`` seconds."""

    def __init__(self, timeout: float) -> None:
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not math.isfinite(timeout) or timeout <= 0:
            raise CommandGuardError(f"timeout must be a positive number of seconds, got {timeout!r}")
        self.timeout = float(timeout)
        self._last: float | None = None

    def mark(self, now: float) -> None:
        """A new pair arrived at ``now`` (seconds on the node's clock)."""
        self._last = now

    def reset(self) -> None:
        """Forget the last arrival (deactivation): stale until the next pair."""
        self._last = None

    def is_stale(self, now: float) -> bool:
        """True before the first pair and once no pair arrived for more than ``timeout``."""
        return self._last is None or not now - self._last <= self.timeout


def outgoing_command(v: float, w: float, *, flip_angular_sign: bool, stale: bool) -> tuple[float, float]:
    """(linear, angular) to publish: zero when stale or not finite, angular negated when flipped."""
    if stale or not (math.isfinite(v) and math.isfinite(w)):
        return 0.0, 0.0
    return v, -w if flip_angular_sign else w
