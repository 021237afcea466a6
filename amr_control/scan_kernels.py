"""The compiled neighbourhood filters of scan_sectors: a scan's running median, running mean and flat mean.

Each is one pass over the beams in numba (cache=True), with the arithmetic of the numpy formulation it replaced
(np.pad, a sliding window, reductions along it): the same values bit for bit, a window's sum taken in numpy's
order (block_sum; windows of at most BLOCK beams). A window of beam i holds beams i - beams // 2 ..
i + beams // 2, wrapped round a full-circle scan (wrap) or with the end beams repeated (np.pad's "edge").
"""

import math

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy", inline="always")
def _neighbour(index, count, wrap):  # pragma: no cover - compiled
    """The beam at window position `index` (may lie off either end of the scan)."""
    if wrap:
        return index % count
    return min(max(index, 0), count - 1)


BLOCK = 128
"""The longest window the filters take: numpy sums a run of at most this many in one block (no recursion)."""


@numba.njit(cache=True, error_model="numpy")
def block_sum(values, count):  # pragma: no cover - compiled
    """values[:count] (count <= BLOCK) summed as numpy's add.reduce sums a contiguous float64 run (pairwise_sum):
    in order below 8, else 8 interleaved partial sums, combined pairwise, then the rest in order."""
    if count < 8:
        total = 0.0
        for i in range(count):
            total += values[i]
        return total
    r0, r1, r2, r3, r4, r5, r6, r7 = (
        values[0],
        values[1],
        values[2],
        values[3],
        values[4],
        values[5],
        values[6],
        values[7],
    )
    i = 8
    while i < count - count % 8:
        r0 += values[i]
        r1 += values[i + 1]
        r2 += values[i + 2]
        r3 += values[i + 3]
        r4 += values[i + 4]
        r5 += values[i + 5]
        r6 += values[i + 6]
        r7 += values[i + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < count:
        total += values[i]
        i += 1
    return total


@numba.njit(cache=True, error_model="numpy")
def running_median(ranges, beams, wrap, jump):  # pragma: no cover - compiled
    """Each beam further than `jump` from the median of its window (np.sort's order: inf last, NaN after) takes
    that median; the others are kept (inf - inf compares False: kept)."""
    count = ranges.size
    half = beams // 2
    out = np.empty(count)
    window = np.empty(beams)
    for i in range(count):
        for k in range(beams):  # insertion sort in np.sort's order: the windows are a few beams
            value = ranges[_neighbour(i - half + k, count, wrap)]
            j = k
            while j > 0 and _before(value, window[j - 1]):
                window[j] = window[j - 1]
                j -= 1
            window[j] = value
        median = window[half]
        out[i] = median if abs(ranges[i] - median) > jump else ranges[i]
    return out


@numba.njit(cache=True, error_model="numpy", inline="always")
def _before(a, b):  # pragma: no cover - compiled
    """a sorts before b in np.sort's order (NaN last)."""
    return a < b or (b != b and a == a)


@numba.njit(cache=True, error_model="numpy")
def _gather(ranges, i, beams, wrap, spread, window):  # pragma: no cover - compiled
    """The `beams` ranges centred on beam i into `window`; whether all are finite and within `spread` (max - min)."""
    count = ranges.size
    low, high = math.inf, -math.inf
    for k in range(beams):
        value = ranges[_neighbour(i - beams // 2 + k, count, wrap)]
        if not math.isfinite(value):
            return False
        low, high = min(low, value), max(high, value)
        window[k] = value
    return high - low <= spread


@numba.njit(cache=True, error_model="numpy")
def running_mean(ranges, beams, wrap, spread):  # pragma: no cover - compiled
    """Each beam the mean of its window where all of it is finite and within `spread` (max - min), else kept."""
    count = ranges.size
    out = np.empty(count)
    window = np.empty(beams)
    for i in range(count):
        smooth = _gather(ranges, i, beams, wrap, spread, window)
        out[i] = block_sum(window, beams) / beams if smooth else ranges[i]
    return out


@numba.njit(cache=True, error_model="numpy")
def flat_mean(ranges, beams, wrap, spread, cosine, keep):  # pragma: no cover - compiled
    """scan_sectors._flat_mean: where a beam's window is all finite, within `spread` and the beam positive, the
    window's straight-line average cosine / mean(1 / r) replaces the beam unless within `keep` (a share of it)."""
    count = ranges.size
    out = np.empty(count)
    inverse = np.empty(beams)
    for i in range(count):
        value = ranges[i]
        out[i] = value
        if not value > 0.0:
            continue
        if _gather(ranges, i, beams, wrap, spread, inverse):
            for k in range(beams):
                inverse[k] = 1.0 / inverse[k]
            average = cosine / (block_sum(inverse, beams) / beams)
            if abs(average - value) > keep * value:
                out[i] = average
    return out


@numba.njit(cache=True, error_model="numpy")
def clean(raw, range_min, range_max):  # pragma: no cover - compiled
    """(ranges, usable): readings within [range_min, range_max] kept, -inf read as range_min, every other
    reading (NaN, +inf, out of range) +inf; usable counts the measurements and the +-inf readings."""
    ranges = np.empty(raw.size)
    usable = 0
    for i in range(raw.size):
        value = raw[i]
        if value >= range_min and value <= range_max:
            ranges[i] = value
            usable += 1
        else:
            ranges[i] = range_min if value == -math.inf else math.inf
            if math.isinf(value):
                usable += 1
    return ranges, usable


@numba.njit(cache=True, error_model="numpy")
def clearance(ranges, forward, forward_cos, forward_sin, band_limit, lidar_x, reach):  # pragma: no cover
    """(travel, side) of scan_sectors.SectorReader._clearance: the least x - sqrt(max(reach^2 - y^2, 0)) over the
    forward returns within the band (r < band_limit) and ahead (x > 0), the first of equal ones, at least 0, and
    the side of its return (+1 left, -1 right); (inf, 0) for none."""
    best = math.inf
    side = 0
    reach_squared = reach * reach
    for k in range(forward.size):
        r = ranges[forward[k]]
        if not r < band_limit[k]:
            continue
        x = lidar_x + r * forward_cos[k]
        if not x > 0.0:
            continue
        y = r * forward_sin[k]
        travel = x - math.sqrt(max(reach_squared - y * y, 0.0))
        if side == 0 or travel < best:
            best = travel
            side = 1 if y > 0.0 else -1
    return max(best, 0.0), side


@numba.njit(cache=True, error_model="numpy")
def fit_points(r, cos, sin):  # pragma: no cover - compiled
    """(n, x, y, sum x, sum y) of a window's returns for scan_sectors._fit_line: beams without a return (r inf)
    are zeroed and not counted; the sums in numpy's order (block_sum: at most BLOCK beams)."""
    count = r.size
    x = np.empty(count)
    y = np.empty(count)
    n = 0
    for i in range(count):
        if r[i] < math.inf:
            n += 1
            x[i] = r[i] * cos[i]
            y[i] = r[i] * sin[i]
        else:
            x[i] = 0.0 * cos[i]
            y[i] = 0.0 * sin[i]
    return n, x, y, block_sum(x, count), block_sum(y, count)
