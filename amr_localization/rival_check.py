"""Before declaring `localized`: is there another place that explains the recent scans as well?

A particle filter's belief is only as wide as its particles. In a world with
two places that look the same, both start with particles, but the sampling
noise of thousands of particles against a 60-beam likelihood soon favours one
of them and the other dies out; the survivor then looks certain. So, before
the filter declares itself localized, this check searches the whole map for a
rival, independently of the particles:

1. coarse: every free position on a `coarse_step` grid times `coarse_headings`
   headings, scored on the current scan by a tolerant likelihood field
   (sigma = coarse_sigma, so that a pose a coarse step off the truth still
   scores well); poses near the estimate are excluded;
2. the best `rivals` candidates, at least a coarse step apart, are refined by a
   pyramidal local search (each level halves the steps) on the history score;
3. history score: the mean per-beam log-likelihood of the last scans, each
   scored at the pose the hypothesis implies then (the hypothesis composed with
   the odometry between then and now), so a place that only looks right from
   here, but not from where the robot just came, scores low.

A rival whose score is within `margin` of the estimate's makes the belief
ambiguous: the filter then gets particles around it and does not declare.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from amr_localization.free_space import FreeSpace
from amr_localization.likelihood_field import LikelihoodField
from amr_localization.scan_beams import Beams
from amr_util.geometry import compose, relative_pose, wrap_angle

NEIGHBOURS = np.stack(np.meshgrid([-1.0, 0.0, 1.0], [-1.0, 0.0, 1.0], [-1.0, 0.0, 1.0], indexing="ij"), -1).reshape(-1, 3)
"""(27, 3) a pose and its neighbours one step away in x, y and heading (the local searches' pattern)."""
CHUNK = 20000
"""poses scored per batch in the coarse search (bounds the (poses x beams) arrays to a few MB)."""


@dataclass(frozen=True)
class RivalCheckParams:
    coarse_step: float = 0.1
    coarse_headings: int = 72
    coarse_beams: int = 30
    rivals: int = 20
    refine_levels: int = 4
    margin: float = 0.05
    """per-beam log-likelihood: a rival this close to the estimate's score is as good (a place that only
    looks the same scored within 0.005 of the truth in twin_rooms; open_room's nearly symmetric other
    corner 0.09-0.14 below, a similar-looking place in inner_maze 0.4 below)."""
    exclusion_radius: float = 0.3
    exclusion_angle: float = math.radians(30.0)


@dataclass(frozen=True)
class Snapshot:
    """A past scan and the odometry pose it was taken at."""

    odometry: tuple[float, float, float]
    beams: Beams
    whole: Beams | None = None
    """the scan's beams before those reading short of the map were dropped (None: `beams` is the whole scan)."""


def history_score(model: LikelihoodField, poses: np.ndarray, history: Sequence[Snapshot], now: tuple[float, float, float]) -> np.ndarray:
    """(N,) mean per-beam log-likelihood of the history for hypotheses `poses` of the current pose."""
    total = np.zeros(len(poses))
    beams = 0
    for snapshot in history:
        used = int(np.count_nonzero(snapshot.beams.returned))
        if used == 0:
            continue
        past = compose(poses, relative_pose(now, snapshot.odometry))
        total += model.log_likelihood(past, snapshot.beams)
        beams += used
    return total / max(beams, 1)


def _subsample(beams: Beams, count: int) -> Beams:
    index = np.flatnonzero(beams.returned)
    if index.size > count:
        index = index[np.linspace(0, index.size - 1, count).round().astype(np.intp)]
    return Beams(beams.ranges[index], beams.angles[index], beams.returned[index], beams.range_max,
                 beams.steps[index] - (beams.steps[index[0]] if index.size else 0), beams.angle_increment)


def coarse_candidates(free_space: FreeSpace, coarse_model: LikelihoodField, beams: Beams, params: RivalCheckParams,
                      estimate: np.ndarray) -> np.ndarray:
    """(M, 3) the best-scoring grid poses away from the estimate, at least a coarse step apart."""
    grid = free_space.grid
    stride = max(1, round(params.coarse_step / grid.resolution))
    mask = np.zeros_like(free_space.mask)
    mask[stride // 2::stride, stride // 2::stride] = True
    rows, cols = np.nonzero(free_space.mask & mask)
    x, y = grid.cell_to_world(rows, cols)
    headings = np.linspace(-math.pi, math.pi, params.coarse_headings, endpoint=False)
    poses = np.column_stack([np.repeat(x, headings.size), np.repeat(y, headings.size), np.tile(headings, x.size)])
    far = (np.hypot(poses[:, 0] - estimate[0], poses[:, 1] - estimate[1]) > params.exclusion_radius) | (
        np.abs(wrap_angle(poses[:, 2] - estimate[2])) > params.exclusion_angle)
    poses = poses[far]
    if len(poses) == 0:
        return poses
    coarse_beams = _subsample(beams, params.coarse_beams)
    scores = np.concatenate([coarse_model.log_likelihood(poses[i:i + CHUNK], coarse_beams)
                             for i in range(0, len(poses), CHUNK)])
    order = np.argsort(-scores, kind="stable")[: 50 * params.rivals]
    chosen: list[np.ndarray] = []
    for pose in poses[order]:
        if all(math.hypot(pose[0] - c[0], pose[1] - c[1]) > params.coarse_step
               or abs(float(wrap_angle(pose[2] - c[2]))) > 2.0 * math.pi / params.coarse_headings for c in chosen):
            chosen.append(pose)
            if len(chosen) == params.rivals:
                break
    return np.array(chosen).reshape(-1, 3)


def refine(model: LikelihoodField, poses: np.ndarray, history: Sequence[Snapshot], now: tuple[float, float, float],
           params: RivalCheckParams) -> tuple[np.ndarray, np.ndarray]:
    """Pyramidal local search of each pose on the history score: 3 x 3 x 3 around the best, steps halving."""
    offsets = NEIGHBOURS
    step = np.array([params.coarse_step / 2.0, params.coarse_step / 2.0, math.pi / params.coarse_headings])
    best = poses.copy()
    scores = history_score(model, best, history, now)
    for _ in range(params.refine_levels):
        trial = (best[:, None, :] + offsets[None, :, :] * step).reshape(-1, 3)
        trial_scores = history_score(model, trial, history, now).reshape(len(best), len(offsets))
        pick = trial_scores.argmax(axis=1)
        better = trial_scores[np.arange(len(best)), pick] > scores
        best[better] = trial.reshape(len(best), len(offsets), 3)[better, pick[better]]
        scores[better] = trial_scores[better, pick[better]]
        step = step / 2.0
    best[:, 2] = wrap_angle(best[:, 2])
    return best, scores


@dataclass(frozen=True)
class PlaceSearch:
    """What one search found: the estimate refined, and the distinct places away from it, best first."""

    own_pose: np.ndarray
    """(3,) the estimate after the local search."""
    own_score: float
    """its history score (mean per-beam log-likelihood)."""
    poses: np.ndarray
    """(M, 3) distinct places away from the estimate, refined."""
    scores: np.ndarray
    """(M,) their history scores."""
    beams: int
    """beams in the history the scores average over (score x beams = the history's log-likelihood)."""

    def within(self, margin: float) -> np.ndarray:
        """(R, 3) the places scoring within `margin` of the estimate (margin < 0: better by -margin at least)."""
        return self.poses[self.scores >= self.own_score - margin].reshape(-1, 3)


def search_places(free_space: FreeSpace, model: LikelihoodField, coarse_model: LikelihoodField,
                  history: Sequence[Snapshot], estimate: np.ndarray, params: RivalCheckParams) -> PlaceSearch:
    """The coarse search and refinement of every candidate, whatever its score (find_rivals keeps the close ones)."""
    now = history[-1].odometry
    beams = sum(int(np.count_nonzero(snapshot.beams.returned)) for snapshot in history)
    own_pose, own_score = refine(model, estimate[None, :], history, now, params)
    candidates = coarse_candidates(free_space, coarse_model, history[-1].beams, params, estimate)
    if len(candidates) == 0:
        return PlaceSearch(own_pose[0], float(own_score[0]), np.zeros((0, 3)), np.zeros(0), beams)
    places, scores = refine(model, candidates, history, now, params)
    away = (np.hypot(places[:, 0] - own_pose[0, 0], places[:, 1] - own_pose[0, 1]) > params.exclusion_radius) | (
        np.abs(wrap_angle(places[:, 2] - own_pose[0, 2])) > params.exclusion_angle)
    order = np.flatnonzero(away)[np.argsort(-scores[away], kind="stable")]
    distinct: list[int] = []  # refinements of neighbouring candidates may meet at one place: keep the best
    for index in order:
        place = places[index]
        if all(math.hypot(place[0] - places[d, 0], place[1] - places[d, 1]) > params.coarse_step
               or abs(float(wrap_angle(place[2] - places[d, 2]))) > params.exclusion_angle for d in distinct):
            distinct.append(int(index))
    return PlaceSearch(own_pose[0], float(own_score[0]), places[distinct].reshape(-1, 3), scores[distinct], beams)


def find_rivals(free_space: FreeSpace, model: LikelihoodField, coarse_model: LikelihoodField, history: Sequence[Snapshot],
                estimate: np.ndarray, params: RivalCheckParams) -> np.ndarray:
    """(R, 3) poses elsewhere that explain the history within `margin` of the estimate (none: unambiguous)."""
    return search_places(free_space, model, coarse_model, history, estimate, params).within(params.margin)
