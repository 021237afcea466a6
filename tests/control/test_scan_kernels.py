"""The compiled scan filters (amr_control.scan_kernels) against the numpy formulation they replaced: the same
values bit for bit, wrapped and edge-padded, on noisy scans with gaps, zeros and scans shorter than the window."""

from __future__ import annotations

import numpy as np
import pytest

from amr_control import scan_sectors
from amr_control.scan_kernels import BLOCK, block_sum, clean, fit_points


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


def numpy_fit_sums(r, cos, sin):
    finite = r < np.inf
    rz = np.where(finite, r, 0.0)
    x, y = rz * cos, rz * sin
    return int(np.count_nonzero(finite)), x, y, float(x.sum()), float(y.sum())


@pytest.mark.parametrize("count", [1, 5, 54, 81, 128])
def test_a_fit_s_points_and_sums_equal_numpy_bit_for_bit(count):
    rng = np.random.default_rng(count)
    angles = rng.uniform(-np.pi, np.pi, count)
    for _ in range(20):
        r = rng.uniform(0.1, 3.0, count)
        r[rng.random(count) < 0.2] = np.inf
        got = fit_points(r, np.cos(angles), np.sin(angles))
        expected = numpy_fit_sums(r, np.cos(angles), np.sin(angles))
        assert got[0] == expected[0] and got[3:] == expected[3:]
        np.testing.assert_array_equal(got[1], expected[1])
        np.testing.assert_array_equal(got[2], expected[2])


def test_cleaning_and_clearance_equal_numpy_bit_for_bit():
    rng = np.random.default_rng(7)
    reader = scan_sectors.SectorReader(
        scan_sectors.Sectors(0.5, 0.7, 0.2), scan_sectors.Footprint(0.105, -0.032, 0.02), median_beams=1
    )
    increment = 2.0 * np.pi / 240
    for _ in range(200):
        raw = rng.uniform(0.0, 4.0, 240)
        for value, share in ((np.nan, 0.05), (np.inf, 0.1), (-np.inf, 0.05), (0.0, 0.05)):
            raw[rng.random(240) < share] = value
        ranges, usable = clean(raw, 0.12, 3.5)
        measured = (raw >= 0.12) & (raw <= 3.5)
        expected = np.where(measured, raw, np.inf)
        expected[raw == -np.inf] = 0.12
        np.testing.assert_array_equal(ranges, expected)
        assert usable == np.count_nonzero(measured) + np.count_nonzero(np.isinf(raw))

        geometry = reader._layout(240, 0.0, increment)
        r = ranges[geometry.forward]
        in_band = r < geometry.band_limit
        x = -0.032 + r[in_band] * geometry.forward_cos[in_band]
        y = r[in_band] * geometry.forward_sin[in_band]
        x, y = x[x > 0.0], y[x > 0.0]
        reach = 0.105 + 0.02
        travel = x - np.sqrt(np.maximum(reach * reach - y * y, 0.0))
        if travel.size:
            nearest = int(np.argmin(travel))
            expected_clearance = (float(max(travel[nearest], 0.0)), 1 if y[nearest] > 0.0 else -1)
        else:
            expected_clearance = (np.inf, 0)
        assert reader._clearance(ranges, geometry) == expected_clearance
