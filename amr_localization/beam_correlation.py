"""How much one scan tells: the weight of each beam and of each scan in the log-likelihood.

The measurement models (likelihood_field.py, beam_model.py) multiply the beams' likelihoods as if
each beam were independent of the others, and the filter multiplies scans as if each scan were
independent of the last. Neither is true: neighbouring beams end on the same stretch of wall, where
the map is off by the same few centimetres, and two scans taken a centimetre apart see the same map
errors, the same clutter and the same person. Counted as independent, 60 beams at 40 scans a second
make the filter overconfident (it locks onto the first place that fits); counted with one cap for
every stream, one scan per metre (a keyframe log) is nearly ignored. Both weights below come from
one correlation model: errors are shared within a length and independent beyond it.

Beams (sensor frame): beams whose end points fall in the same beam_correlation_length square share
one beam's weight,

    w_k = 1 / |{j : cell(e_j) = cell(e_k)}|,    sum_k w_k = number of distinct cells

so a scan counts as many independent beams as it has distinct stretches of wall in view, whatever
its angular resolution or max_beams.

Scans: a scan taken after the robot moved d and turned a since the last scan used counts

    g = min(1, d / scan_correlation_distance + a / (1.5 scan_correlation_distance))

(1.5 rad of turning per metre of travel: a turn of 0.3 rad moves a wall 2 m away by 0.6 m). At 40 scans
a second each scan adds its small share; a scan per metre counts fully. A scan's log-likelihood is

    log p(z | x) = g sum_k w_k log p(z_k | x)
"""

from __future__ import annotations

import numpy as np

from amr_localization.scan_beams import Beams

TURN_PER_METRE = 1.5
"""rad of turning that decorrelates two scans as much as one scan_correlation_distance of travel (per metre)."""


def beam_weights(beams: Beams, length: float) -> np.ndarray:
    """(K,) each selected beam's weight: 1 / the count of returned beams whose end points share its cell of side
    `length` (sensor frame); 0 for beams without a return; 1 for every returned beam when length is 0."""
    returned = beams.returned
    weights = returned.astype(float)
    if length <= 0.0 or not returned.any():
        return weights
    ends = np.column_stack([beams.ranges * np.cos(beams.angles), beams.ranges * np.sin(beams.angles)])[returned]
    _, cell, counts = np.unique(
        np.floor(ends / length).astype(np.int64), axis=0, return_inverse=True, return_counts=True
    )
    weights[returned] = 1.0 / counts[cell.ravel()]
    return weights


def scan_weight(moved: float, turned: float, distance: float) -> float:
    """The share g in [0, 1] of a scan's log-likelihood that counts, after moving `moved` m and turning `turned`
    rad since the last scan used (see the module's docstring); 1 when distance is 0 (every scan independent)."""
    if distance <= 0.0:
        return 1.0
    return min(1.0, abs(moved) / distance + abs(turned) / (TURN_PER_METRE * distance))


def beams_in_view(weights: np.ndarray) -> float:
    """The number of independent beams a scan counts as (the sum of its beam weights)."""
    return float(np.sum(weights)) if len(weights) else 0.0
