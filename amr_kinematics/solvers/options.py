"""Checks of solver-specific options: one clear InvalidRequestError per bad value."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidRequestError


def number(name: str, value, *, low: float = 0.0, high: float = math.inf, allow_low: bool = True) -> float:
    """A finite real in [low, high] (or (low, high] when allow_low is False)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InvalidRequestError(f"option {name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value > high or value < low or (not allow_low and value == low):
        bound = "[" if allow_low else "("
        raise InvalidRequestError(f"option {name} must be in {bound}{low}, {high}], got {value}")
    return value


def integer(name: str, value, *, low: int = 1, high: int = 1_000_000) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise InvalidRequestError(f"option {name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


def axis_tolerance(value, dims: int) -> tuple[float, ...] | None:
    """None, or one positive bound per position axis (x, y[, z])."""
    if value is None:
        return None
    try:
        values = tuple(float(v) for v in value)
    except (TypeError, ValueError) as exc:
        raise InvalidRequestError(f"option axis_tolerance must be a list of numbers, got {value!r}") from exc
    if len(values) not in (dims, 3) or not all(math.isfinite(v) and v > 0.0 for v in values):
        raise InvalidRequestError(f"option axis_tolerance needs {dims} positive finite bounds, got {value!r}")
    return values


def choice(name: str, value, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise InvalidRequestError(f"option {name} must be one of {allowed}, got {value!r}")
    return value
