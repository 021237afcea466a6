"""The compiled loop of raycast.cast_discs: every (observer, disc) pair's beams, in numba.

Kept apart so that importing the simulator does not import numba: only a fleet's scans need it.
"""

import math

import numba

from amr_util.geometry import TWO_PI


@numba.njit(cache=True)
def sweep_discs(ranges, x, y, phi0, increment, period, max_range, centres, radius, skip):  # pragma: no cover
    """ranges[n, beam] = min(itself, the beam's first hit on a disc) for every origin n and every disc but
    skip[n] within reach; a disc spans the beams within asin(radius / d) of its bearing, on the fan's
    first turn (k = beam) and, for a fan straddling k = 0, its second (k = beam + period)."""
    count = ranges.shape[1]
    for origin in range(x.size):
        for disc in range(centres.shape[0]):
            if disc == skip[origin]:
                continue
            dx, dy = centres[disc, 0] - x[origin], centres[disc, 1] - y[origin]
            distance = math.hypot(dx, dy)
            if distance - radius >= max_range:
                continue
            start = phi0[origin] - math.atan2(dy, dx)  # the first beam's angle from the bearing
            half = math.asin(radius / distance) if distance > radius else math.pi
            k_lo = ((-start - half) % TWO_PI) / increment
            k_hi = k_lo + 2.0 * half / increment
            for turn in (0.0, period):  # beam j sits at k = j and, one turn on, at k = j + period
                first = max(math.ceil(k_lo - turn), 0)
                last = min(math.floor(k_hi - turn), count - 1)
                for beam in range(first, last + 1):
                    angle = start + increment * beam
                    across = distance * math.sin(angle)
                    hit = max(distance * math.cos(angle) - math.sqrt(max(radius * radius - across * across, 0.0)), 0.0)
                    if hit < ranges[origin, beam]:
                        ranges[origin, beam] = hit
