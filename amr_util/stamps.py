"""Time stamps: nanoseconds, seconds and builtin_interfaces/Time, converted one way everywhere.

A stamp (sec, nanosec) is int(sec) * 1e9 + nanosec integer nanoseconds; seconds are floats. rclpy's
`Time.from_msg(stamp).nanoseconds` gives the same integer for a node; these need no node and no clock.
"""

from __future__ import annotations

from builtin_interfaces.msg import Time

NANOSECONDS_PER_SECOND = 1_000_000_000


def to_nanoseconds(sec: int, nanosec: int) -> int:
    """Integer nanoseconds of a ``builtin_interfaces/Time`` (sec, nanosec) pair."""
    return int(sec) * NANOSECONDS_PER_SECOND + int(nanosec)


def stamp_nanoseconds(stamp) -> int:
    """Integer nanoseconds of a builtin_interfaces/Time (or anything with sec and nanosec)."""
    return to_nanoseconds(stamp.sec, stamp.nanosec)


def stamp_seconds(stamp) -> float:
    """Seconds of a builtin_interfaces/Time (or anything with sec and nanosec), as a float."""
    return stamp.sec + stamp.nanosec * 1e-9


def stamp_from_nanoseconds(total: int) -> Time:
    """A builtin_interfaces/Time of integer nanoseconds (>= 0)."""
    return Time(sec=total // NANOSECONDS_PER_SECOND, nanosec=total % NANOSECONDS_PER_SECOND)


def stamp_from_seconds(seconds: float) -> Time:
    """A builtin_interfaces/Time of seconds (>= 0), rounded to the nearest nanosecond."""
    return stamp_from_nanoseconds(round(seconds * NANOSECONDS_PER_SECOND))
