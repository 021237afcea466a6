"""The compiled scan filters (amr_control.scan_kernels) against the numpy formulation they replaced: the same
values bit for bit, wrapped and edge-padded, on noisy scans with gaps, zeros and scans shorter than the window."""

from __future__ import annotations

import numpy as np
import pytest

from amr_control import scan_sectors
from amr_control.scan_kernels import BLOCK, block_sum


def _windows(ranges: np.ndarray, beams: int, wrap: bool) -> np.ndarray:
    padded = np.pad(ranges, beams // 2, mode="wrap" if wrap else "edge")
    return np.lib.stride_tricks.sliding_window_view(padded, beams)


def numpy_running_median(ranges, beams, wrap):
    median = np.sort(_windows(ranges, beams, wrap), axis=1)[:, beams // 2]
    with np.errstate(invalid="ignore"):
        jump = np.abs(ranges - median) > scan_sectors.OUTLIER_JUMP
    return np.where(jump, median, ranges)


def numpy_running_mean(ranges, beams, wrap):
    windows = _windows(ranges, beams, wrap)
    with np.errstate(invalid="ignore"):
        smooth = np.all(np.isfinite(windows), axis=1) & (np.ptp(windows, axis=1) <= scan_sectors.SMOOTH_SPREAD)
    return np.where(smooth, np.where(smooth[:, None], windows, 0.0).mean(axis=1), ranges)


def numpy_flat_mean(ranges, beams, increment, wrap):
    if beams <= 1:
        return ranges
    half = beams // 2
    windows = _windows(ranges, beams, wrap)
    with np.errstate(invalid="ignore", divide="ignore"):
        smooth = (
            np.all(np.isfinite(windows), axis=1)
            & (np.ptp(windows, axis=1) <= scan_sectors.FLAT_SPREAD)
            & (ranges > 0.0)
        )
        inverse = np.where(smooth[:, None], 1.0 / windows, 0.0).mean(axis=1)
        cosine = float(np.cos(increment * np.arange(-half, half + 1)).mean())
        average = cosine / np.where(smooth, inverse, 1.0)
        return np.where(smooth & (np.abs(average - ranges) > scan_sectors.KEEP_SHARE * ranges), average, ranges)


def _scans(seed: int):
    rng = np.random.default_rng(seed)
    for count in (1, 2, 3, 6, 240, 360):
        for _ in range(8):
            walls = np.repeat(rng.uniform(0.1, 3.0, count // 6 + 1), 6)[:count]
            ranges = walls + rng.normal(0.0, 0.03, count)
            ranges[rng.random(count) < 0.1] = np.inf
            ranges[rng.random(count) < 0.03] = 0.0
            yield ranges


@pytest.mark.parametrize("wrap", [True, False])
@pytest.mark.parametrize("beams", [1, 3, 5, 7, 9, 17, 61, 127])
def test_the_compiled_filters_equal_numpy_bit_for_bit(beams, wrap):
    compared = 0
    for ranges in _scans(beams):
        got = (
            scan_sectors._running_median(ranges, beams, wrap),
            scan_sectors._running_mean(ranges, beams, wrap),
            scan_sectors._flat_mean(ranges, beams, 0.0262, wrap),
        )
        expected = (
            numpy_running_median(ranges, beams, wrap),
            numpy_running_mean(ranges, beams, wrap),
            numpy_flat_mean(ranges, beams, 0.0262, wrap),
        )
        for a, b in zip(got, expected, strict=True):
            np.testing.assert_array_equal(a, b)
            compared += 1
    assert compared == 6 * 8 * 3


@pytest.mark.parametrize("count", [0, 1, 7, 8, 9, 16, 23, 61, 128])
def test_block_sum_adds_as_numpy_does(count):
    values = np.random.default_rng(count).uniform(0.1, 3.0, count) ** 3
    assert block_sum(values, count) == np.add.reduce(values)


def test_a_window_wider_than_a_block_is_refused():
    with pytest.raises(ValueError, match="at most 128 beams"):
        scan_sectors._running_mean(np.ones(400), BLOCK + 1, True)
