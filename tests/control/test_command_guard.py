"""Stale data stops the robot; the angular sign follows the robot's convention."""

from __future__ import annotations

import math

import pytest

from amr_control.command_guard import CommandGuardError, FreshnessWatchdog, outgoing_command


def test_watchdog_is_stale_until_the_first_pair_and_after_the_timeout():
    dog = FreshnessWatchdog(0.1)
    assert dog.is_stale(0.0)
    dog.mark(1.0)
    assert not dog.is_stale(1.05)
    assert not dog.is_stale(1.099)
    assert dog.is_stale(1.101)
    dog.reset()
    assert dog.is_stale(1.0)


@pytest.mark.parametrize("timeout", [0.0, -1.0, math.nan, math.inf, True, "0.1"])
def test_watchdog_refuses_bad_timeouts(timeout):
    with pytest.raises(CommandGuardError):
        FreshnessWatchdog(timeout)


def test_outgoing_command():
    assert outgoing_command(0.15, 0.3, flip_angular_sign=False, stale=False) == (0.15, 0.3)
    assert outgoing_command(0.15, 0.3, flip_angular_sign=True, stale=False) == (0.15, -0.3)
    assert outgoing_command(0.15, 0.3, flip_angular_sign=True, stale=True) == (0.0, 0.0)
    assert outgoing_command(math.nan, 0.3, flip_angular_sign=False, stale=False) == (0.0, 0.0)
