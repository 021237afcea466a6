"""What the particles forget about look-alike places: their accumulated log-evidence (issue 20).

In a room that one small feature alone tells apart from its rotated copies, the
scans that see the feature (or a wall where a copy would see it) are the only
ones that weigh the copies against each other, and they come for a few seconds
per lap. Measured (docs/localization_symmetry.md), the filter lost them: its
likelihood field cannot see a doorway (a beam through it ends near a wall in
every copy), tempering used part of what it saw, the particles of a copy with
nothing against it drifted away by chance, and, worst, the rival search before
each declaration, which looks at the last metre of scans only, found the copies
explaining those scans as well as the estimate and gave each a cloud as heavy as
the estimate's: what had been seen was reset to even odds again and again.

The ledger keeps it. Each entry is one hypothesis of the robot's pose (the places
the rival search finds, from the first scan on, and the estimate's); every filter
update moves each entry by the odometry increment, re-fits it to the scan by a
small local search on the likelihood field (robot-frame steps: it does not drift
off the map, and two mirror-image entries stay mirror images), and adds the scan's
log-likelihood there to its evidence: untempered, times the weight the particles
give a scan, and with each beam's free path checked (LikelihoodField.
log_likelihood_free_path: a beam that went through a place's wall, or no return
where a wall stands in range, scores as a random reading), so that a doorway seen
counts. The evidence is kept relative to the best entry (0); an entry `threshold`
below it is ruled out, one that leaves free space for good.

Small differences are not evidence: each beam's term is its best within a couple
of cm and a degree of the entry (a grazed corner is pose error), and a beam whose
term differs from the best entry's by less than `dead_zone` adds nothing (a wall
rasterized a cell off at one copy and not at the other: in rooms mapped off the
2 cm lattice such differences stayed under 1.35, 99.9 % under 0.25, while a
feature's beams differ by 3-5.5); summed over thousands of scans they would
otherwise become a confident answer in a world that stays symmetric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_localization.free_space import FreeSpace
from amr_localization.likelihood_field import LikelihoodField
from amr_localization.rival_check import NEIGHBOURS
from amr_localization.scan_beams import Beams
from amr_util.geometry import compose, wrap_angle

_AXES = np.vstack([np.zeros(3), np.eye(3), -np.eye(3)])
"""the pose and one step either way along, across and in heading: the free-path tolerance (a ray-marched term
costs about 30 times a likelihood-field lookup, so 7 poses rather than the refinement's 27)."""


@dataclass(frozen=True)
class LedgerParams:
    threshold: float = 8.0
    """log-evidence: an entry this far below the best one is ruled out (odds e^8, about 3,000:1)."""
    dead_zone: float = 1.0
    """log-likelihood: a beam whose term differs between an entry and the best fitting one by less than this
    adds nothing to either (map and pose error; a feature's beams differ by 3-5.5)."""
    match_distance: float = 0.3
    """m: a pose this close to an entry (and within match_angle) is that entry's place."""
    match_angle: float = math.radians(30.0)
    max_entries: int = 48
    floor: float = -200.0
    """log-evidence is kept above this (ruled out long ago; bounded numbers)."""
    settle_updates: int = 5
    """scans a new entry is only fitted to (from the rival search's pose, up to a few cm off) before its
    evidence counts: a place must not lose evidence while its pose is still being found."""
    refine_levels: int = 3
    refine_step: float = 0.02
    """m, the local search's first step along and across the robot (halved at each level)."""
    refine_angle: float = math.radians(2.0)
    free_path_margin: float = 0.1
    """m: a beam's path must be free up to this short of its end point (LiDAR noise and the entry's pose error)."""
    free_path_step: float = 0.02
    """m, and free_path_angle: each beam's term is its best at the entry or one such step away."""
    free_path_angle: float = math.radians(2.0)


class EvidenceLedger:
    """Hypotheses of the pose with their accumulated log-evidence. Not thread-safe."""

    def __init__(self, model: LikelihoodField, free_space: FreeSpace, params: LedgerParams | None = None) -> None:
        self.model = model
        self.free_space = free_space
        self.params = params or LedgerParams()
        self.clear()

    def clear(self) -> None:
        self.poses = np.zeros((0, 3))
        self.evidence = np.zeros(0)
        self.age = np.zeros(0, dtype=np.int64)
        """scans each entry has been fitted to; the first settle_updates add no evidence."""

    def __len__(self) -> int:
        return len(self.poses)

    def move(self, increment: np.ndarray) -> None:
        """Every entry moved by the odometry increment (robot frame). An entry that leaves free space is ruled
        out for good (evidence floor), as a particle crossing a wall dies; it is kept, so that the rival search
        finding its place again later (out of the wall) does not bring it back as a new, even one."""
        if not len(self):
            return
        self.poses = compose(self.poses, increment)
        inside = self.free_space.contains(self.poses[:, 0], self.poses[:, 1])
        self.evidence = np.where(inside, self.evidence, -np.inf)
        self._normalize()

    def observe(self, beams: Beams, weight: float, short_of=None) -> None:
        """Re-fit each entry to the scan and add the scan's log-likelihood at it, times `weight`, to its evidence.
        short_of: a function (K, 3) poses -> (K, beams) whether each beam reads short of the map there (something
        not on the map in front); given, such a beam counts for no entry against the others: a place is not
        ruled out because another robot stands where it has free space (the filter passes it while contested)."""
        if not len(self) or not beams.returned.any():
            return
        self.poses, _ = self._refine(beams)
        terms = self._free_path_terms(beams)
        if short_of is not None:  # a short reading scores every entry as the best does
            short = np.asarray(short_of(self.poses), dtype=bool)
            terms = np.where(short.any(axis=0)[None, :], terms.max(axis=0)[None, :], terms)
        settled = self.age >= self.params.settle_updates
        self.age = self.age + 1
        if not settled.any():
            return
        score = terms.sum(axis=1)
        reference = terms[np.flatnonzero(settled)[np.argmax(score[settled])]]
        difference = terms - reference
        difference[np.abs(difference) < self.params.dead_zone] = 0.0
        gain = np.where(settled, difference.sum(axis=1), 0.0)
        self.evidence = self.evidence + weight * gain
        self._normalize()

    def find(self, pose: np.ndarray) -> int:
        """Index of the entry at `pose`'s place (the best-supported one if several), -1 if none."""
        if not len(self):
            return -1
        pose = np.asarray(pose, float)
        near = (np.hypot(self.poses[:, 0] - pose[0], self.poses[:, 1] - pose[1]) <= self.params.match_distance) & (
            np.abs(wrap_angle(self.poses[:, 2] - pose[2])) <= self.params.match_angle)
        if not near.any():
            return -1
        index = np.flatnonzero(near)
        return int(index[np.argmax(self.evidence[index])])

    def add(self, pose: np.ndarray, evidence: float) -> int:
        """A new entry (or, at an entry's place, that entry: its evidence is kept). Returns its index."""
        found = self.find(pose)
        if found >= 0:
            return found
        if len(self) >= self.params.max_entries:  # forget the least supported place
            keep = np.zeros(len(self), dtype=bool)
            keep[np.argsort(-self.evidence, kind="stable")[: self.params.max_entries - 1]] = True
            self._keep(keep)
        self.poses = np.vstack([self.poses, np.asarray(pose, float)[None, :3]])
        self.evidence = np.append(self.evidence, float(evidence))
        self.age = np.append(self.age, 0)
        self._normalize()
        return len(self) - 1

    def ruled_out(self) -> np.ndarray:
        """(K,) whether each entry is threshold or more below the best one."""
        return self.evidence <= -self.params.threshold

    def near(self, poses: np.ndarray, index: int) -> np.ndarray:
        """(N,) whether each of `poses` lies at entry `index`'s place."""
        entry = self.poses[index]
        return (np.hypot(poses[:, 0] - entry[0], poses[:, 1] - entry[1]) <= self.params.match_distance) & (
            np.abs(wrap_angle(poses[:, 2] - entry[2])) <= self.params.match_angle)

    def _free_path_terms(self, beams: Beams) -> np.ndarray:
        """(K, beams) each beam's free-path log-likelihood term at its best within one tolerance step
        (free_path_step, free_path_angle) of each entry: a beam that grazes a corner, or meets a wall a
        cell off where the map was rasterized, at the entry's pose but not a couple of cm or a degree away
        is pose or map error, not evidence; a wall across a doorway's view stays a wall a few cm away."""
        step = np.array([self.params.free_path_step, self.params.free_path_step, self.params.free_path_angle])
        trial = self._around(self.poses, _AXES * step)
        terms = self.model.log_likelihood_free_path(trial, beams, self.params.free_path_margin, per_beam=True)
        return terms.reshape(len(self), len(_AXES), -1).max(axis=1)

    @staticmethod
    def _around(poses: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """(K x M, 3) each pose composed with each robot-frame offset."""
        c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
        return np.stack([poses[:, None, 0] + c * offsets[:, 0] - s * offsets[:, 1],
                         poses[:, None, 1] + s * offsets[:, 0] + c * offsets[:, 1],
                         poses[:, None, 2] + offsets[:, 2]], axis=-1).reshape(-1, 3)

    def _refine(self, beams: Beams) -> tuple[np.ndarray, np.ndarray]:
        """Each entry's best pose near it (robot-frame steps halving) and its log-likelihood there."""
        best = self.poses.copy()
        score = self.model.log_likelihood(best, beams)
        step = np.array([self.params.refine_step, self.params.refine_step, self.params.refine_angle])
        count = len(best)
        for _ in range(self.params.refine_levels):
            offsets = NEIGHBOURS * step
            trial = self._around(best, offsets)
            trial_score = self.model.log_likelihood(trial, beams).reshape(count, len(offsets))
            pick = trial_score.argmax(axis=1)
            better = trial_score[np.arange(count), pick] > score
            best[better] = trial.reshape(count, len(offsets), 3)[better, pick[better]]
            score[better] = trial_score[better, pick[better]]
            step = step / 2.0
        best[:, 2] = wrap_angle(best[:, 2])
        return best, score

    def _normalize(self) -> None:
        """Best evidence 0, none below floor; two entries that met at one place become one (the better one)."""
        if not len(self):
            return
        best = self.evidence.max()
        self.evidence = np.maximum(self.evidence - (best if np.isfinite(best) else 0.0), self.params.floor)
        keep: list[int] = []
        for index in np.argsort(-self.evidence, kind="stable"):
            if not any(self.near(self.poses[index][None, :], other)[0] for other in keep):
                keep.append(int(index))
        if len(keep) < len(self):
            mask = np.zeros(len(self), dtype=bool)
            mask[keep] = True
            self._keep(mask)

    def _keep(self, mask: np.ndarray) -> None:
        self.poses, self.evidence, self.age = self.poses[mask], self.evidence[mask], self.age[mask]
