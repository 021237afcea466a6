"""Beams on objects the map lacks, weighed by the belief: the distance filter (Fox, Burgard and Thrun 1999).

The places' measurement model (likelihood field with the beam's free path, likelihood_field.py) scores a beam that
something the map lacks stopped short (another robot, a person, a box) at its random floor at the true place, and as a
hit at any other place whose map has a wall where the beam ended. The true place can never win such a beam, and the
same object is seen again at every scan while it stays in view: counted as the map's evidence, objects the map lacks
draw the places' odds towards look-alikes, by about 4-5 nats a beam at full weight (the localization record's
eighteenth pass: a robot localized for a minute beside another, turning in place, lost its true place to a
look-alike 2.3 m away in 1.7 s).

Fox, Burgard and Thrun ("Markov localization for mobile robots in dynamic environments", JAIR 11, 1999) give each
beam a hidden cause, the map or an unmodelled object. Given the robot is at place x_i, the probability that beam k
was stopped short by an unmodelled object is its random reading's share of its likelihood,

    r_ik = [path to z_k clear at x_i] (z_rand / range_max) / p(z_k | x_i)  =  clear_ik exp(floor - log p(z_k | x_i)),

(a beam through a wall of x_i is the map's word against x_i, never an object: an object only shortens a beam), and
under the belief P(x_i) over the places the beam is on an unmodelled object with probability

    P(unmodelled_k) = sum_i P(x_i) r_ik .

Their distance filter leaves out of the places' odds the beams with P(unmodelled_k) > 0.99 (UNMODELLED_THRESHOLD).
A beam the believed place calls short then no longer moves the odds between that place and a look-alike (it tells
only what the belief already holds). Only a belief all but certain leaves a beam out: while the places are in
doubt (global localization, a look-alike rising) every beam counts, so a place believed wrongly is not shielded from
the beams that speak against it (a continuous share, w_k (1 - P(unmodelled_k)), did shield it: in the crowded bench's
global runs a place 3.6 m off at 0.79 discounted the beams against it and was declared). `elsewhere` explains no
beam in particular (r = 0 there). The places' odds and `elsewhere`'s marginal are scored with these weights; the
choice of a pose within a place (fits, re-anchoring, the estimate) and the particles keep the beams' own: a beam
short of the believed pose's wall is as likely that pose's own error along the beam.
"""

from __future__ import annotations

import numpy as np

UNMODELLED_THRESHOLD = 0.99
"""a beam is left out of the places' odds where the belief says an object the map lacks stopped it with more than this
probability (Fox, Burgard and Thrun's 0.99)."""


def mapped_share(probabilities: np.ndarray, terms: np.ndarray, clear: np.ndarray, floor: float) -> np.ndarray:
    """(K,) 0 for each beam the belief says an object the map lacks stopped (sum_i P(x_i) r_ik above
    UNMODELLED_THRESHOLD), 1 for the others.

    probabilities: (H,) the places' posterior (summing to at most 1: the rest is `elsewhere`'s); terms: (H, K) each
    beam's log-likelihood at each place (the places' model); clear: (H, K) whether the beam's path is clear of the
    map's walls to its end at each place; floor: the model's log z_rand / range_max."""
    probabilities = np.asarray(probabilities, dtype=float)
    if not probabilities.size:
        return np.ones(np.shape(terms)[-1])
    unmodelled = np.where(clear, np.exp(np.minimum(floor - np.asarray(terms, dtype=float), 0.0)), 0.0)
    return np.where(probabilities @ unmodelled > UNMODELLED_THRESHOLD, 0.0, 1.0)
