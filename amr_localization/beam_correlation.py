"""How much one scan tells: the weight of each beam and of each scan in the log-likelihood.

The measurement models (likelihood_field.py, beam_model.py) multiply the beams' likelihoods as if
each beam were independent of the others, and the filter multiplies scans as if each scan were
independent of the last. Neither is true: neighbouring beams end on the same stretch of wall, where
the map is off by the same few centimetres, and two scans taken a centimetre apart see the same map
errors, the same clutter and the same person. Counted as independent, 60 beams at 40 scans a second
make the filter overconfident (it locks onto the first place that fits); counted with one cap for
every stream, one scan per metre (a keyframe log) is nearly ignored. Both weights below come from
one correlation model: errors are shared within a length and independent beyond it.

Beams (sensor frame): the errors of two beams are correlated by the distance d between their end points,
rho(d) = exp(-d / beam_correlation_length), and each beam's weight is its share of the independent ones,

    w_k = 1 / sum_j rho(|e_j - e_k|),    sum_k w_k = the scan's count of independent beams

(the design effect of a correlated sample: n beams on one spot count once, n beams far apart n times), so a
scan counts as many independent beams as it has stretches of wall in view, whatever its angular resolution or
max_beams. On real robots' logs (bench/bench_beam_correlation.py: the places' per-beam log-likelihood at the
corrected poses) the correlation is 0.8-1.0 within 0.25 m, 0.4-0.9 at 0.25-0.5 m, 0.2-0.8 at 0.5-1 m and fits
the exponential with a length of 0.5-0.6 m in two buildings, 1.4-1.9 m in two others: a person, a cupboard, a
door left open or a wall the map got wrong spoils every beam that ends on it, not one. In the simulator's worlds,
whose map is the world, it is under 0.05 m. The length is thus the map's fidelity, and configuration: 0.12 m in
config/particle_filter.yaml (the simulator's; the count of independent beams the simulation figures were validated
with), 0.5 m in config/particle_filter_real.yaml (a real building's).

Scans: a scan taken after the robot moved d and turned a since the last scan used counts

    g = min(1, d / scan_correlation_distance + a / (1.5 scan_correlation_distance))

(1.5 rad of turning per metre of travel: a turn of 0.3 rad moves a wall 2 m away by 0.6 m). At 40 scans
a second each scan adds its small share; a scan per metre counts fully. A scan's log-likelihood is

    log p(z | x) = g sum_k w_k log p(z_k | x)
"""

from __future__ import annotations

import math

import numba
import numpy as np

from amr_localization.scan_beams import Beams

TURN_PER_METRE = 1.5
"""rad of turning that decorrelates two scans as much as one scan_correlation_distance of travel (per metre)."""


def beam_weights(beams: Beams, length: float) -> np.ndarray:
    """(K,) each selected beam's weight: 1 / the sum of its correlations exp(-d / length) with the returned beams
    (itself included; d between end points, sensor frame); 0 for beams without a return; 1 for every returned
    beam when length is 0."""
    returned = beams.returned
    weights = returned.astype(float)
    if length <= 0.0 or not returned.any():
        return weights
    ends = np.column_stack([beams.ranges * np.cos(beams.angles), beams.ranges * np.sin(beams.angles)])[returned]
    weights[returned] = 1.0 / correlation_sums(ends, length)
    return weights


def correlation_sums(points: np.ndarray, length: float) -> np.ndarray:
    """(K,) for each of the (K, 2) points, the sum of exp(-d / length) over every point (itself included, 1)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    sums = np.ones(len(points))
    if length > 0.0 and len(points) > 1:
        _correlation_sums(np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1]), 1.0 / length, sums)
    return sums


def independent_count(points: np.ndarray, length: float) -> float:
    """How many independent points the (K, 2) points count as: the sum of 1 / correlation_sums (K when length is
    0 or the points lie far apart, 1 for points on one spot)."""
    return float(np.sum(1.0 / correlation_sums(points, length))) if len(points) else 0.0


@numba.njit(cache=True, nogil=True)
def _correlation_sums(x, y, inverse_length, sums):
    """sums[i] += exp(-|p_i - p_j| / length) over j != i, each pair once: (K, K) distances without the array."""
    count = x.size
    for i in range(count):
        for j in range(i + 1, count):
            term = math.exp(-math.sqrt((x[i] - x[j]) ** 2 + (y[i] - y[j]) ** 2) * inverse_length)
            sums[i] += term
            sums[j] += term


def scan_weight(moved: float, turned: float, distance: float) -> float:
    """The share g in [0, 1] of a scan's log-likelihood that counts, after moving `moved` m and turning `turned`
    rad since the last scan used (see the module's docstring); 1 when distance is 0 (every scan independent)."""
    if distance <= 0.0:
        return 1.0
    return min(1.0, abs(moved) / distance + abs(turned) / (TURN_PER_METRE * distance))


def beams_in_view(weights: np.ndarray) -> float:
    """The number of independent beams a scan counts as (the sum of its beam weights)."""
    return float(np.sum(weights)) if len(weights) else 0.0
