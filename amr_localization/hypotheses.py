"""Place hypotheses and their posterior probabilities: the one place where "localized" is decided.

A particle filter's clusters are its places, but a cluster is not a probability one can trust: the
particles of a place that looks like another one can die out by chance at resampling, a place no
particle is near has no say at all, and a cloud's weight forgets everything older than its last
resampling. Here each place the robot may be at is a hypothesis h_i with a pose and a log-evidence
L_i, and (mixture MCL, Thrun, Fox, Burgard and Dellaert 2001; multi-hypothesis localization, Jensfelt
and Kristensen 2001):

- hypotheses are born from the particles' clusters and from the place search's proposals (a
  correlative scan matcher over the whole map, amr_maps.scan_matcher), and move with odometry;
- every scan adds the measurement model's log-likelihood at each hypothesis's pose (the same model,
  the same beam and scan weights as the particles: beam_correlation.py) to its L_i;
- a hypothesis born now was not there for the scans before: it is given the evidence of the
  strongest one, corrected by what the recent scans (those kept in the window) say against it,

      L_new = L_ref + min(0, sum_{j in window} g_j (log p(z_j | x_new,j) - log p(z_j | x_ref,j))),

  so that a place that explains every scan as well as the estimate is as likely as the estimate, one
  ruled out by a scan still in the window stays ruled out, and none starts above the strongest: a place
  overtakes it only by the scans it is followed through (after a kidnapping the belief passes through
  doubt before it settles on the new place);
- one more hypothesis, `elsewhere`, is the robot at none of the places followed (Jensfelt and Kristensen's
  null hypothesis); its evidence grows by the data's marginal likelihood over the places not followed,
  estimated on a fixed sample of poses spread over free space and on the peaks the running place search has
  met where no place is followed, each holding the share v / V of the map's poses a peak takes
  (ParticleFilter._elsewhere),

      L_elsewhere += log (1/M sum_m p(z | x_m) + sum_k p(z | x_k) v / V),

  which a place the robot is at beats by far, and a place it is not at (a kidnapped robot's old place, a
  look-alike) does not once the search has met where the robot is;
- the posterior is P(h_i) = exp(L_i) / (exp(L_elsewhere) + sum_j exp(L_j)), each L kept within
  MAX_LOG_ODDS of the best place's, elsewhere's too, either way (a robot may be carried anywhere, to a place
  followed as well as away from it: a kidnapping's prior, which also keeps the numbers finite);
- a hypothesis whose pose, as the scan places it, is in a wall is impossible and dies (its pose moved by the
  scan-matched odometry and fitted to the scan: odometry alone can end a keyframe's step in a wall beside the
  robot's true path), its belief going to `elsewhere` (not to the places left); at most MAX_HYPOTHESES are kept,
  the least likely forgotten first.

The filter then makes its particles agree (sensor resetting, Lenser and Veloso 2000): each place holds
as much particle weight as its probability, a likely place without particles gets a cloud. `localized`
is the best hypothesis's probability, times the share of the belief the hypotheses hold, against
localized_probability, with hysteresis down to release_probability; it is withdrawn too when the best place is no
longer the one declared, told by its identity (`ids`), which a place keeps however far a scan's fit moves it.
Until a place search has covered the map the hypotheses are not a partition of it, and the confidence is 0.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from amr_util.geometry import compose, wrap_angle

MAX_HYPOTHESES = 16
"""places followed at once; the least likely is forgotten when a new one is born beyond this."""
MAX_LOG_ODDS = 30.0
"""log-evidence: no hypothesis falls further than this below the best (a kidnapping's prior, e^-30 per place)."""
MERGE_DISTANCE = 0.3
"""m: a proposal or cluster this close to a hypothesis (and within MERGE_ANGLE of its heading) is that place."""
MERGE_ANGLE = math.radians(20.0)
"""rad: see MERGE_DISTANCE."""


class PlaceHypotheses:
    """Poses (H, 3) with log-evidence (H,), heaviest first after every change, and the log-evidence of `elsewhere`:
    the robot at none of them (Jensfelt and Kristensen's null hypothesis). Evidence is kept relative to the best
    place (its evidence is 0)."""

    def __init__(self) -> None:
        self._next_id = 0
        self.clear()

    def __len__(self) -> int:
        return len(self.evidence)

    def clear(self) -> None:
        self.poses, self.evidence = np.zeros((0, 3)), np.zeros(0)
        self.variance = np.zeros(0)
        """(H,) m^2: the motion's position variance each place has been moved by since particles last held it (a
        place without particles is carried by odometry and the window's links alone: it is fitted within 3 sigma)."""
        self.ids = np.zeros(0, dtype=np.int64)
        """(H,) each place's identity, kept while it is followed (moved, fitted, re-anchored, ranked): "the place
        declared" is a place, not a pose. Never reused, across clears too."""
        self._absorbed: dict[int, int] = {}
        """a place merged into another: its identity -> the other's (index_of follows it)."""
        self.elsewhere = 0.0

    def move(self, increment, variance: float = 0.0) -> None:
        """Every hypothesis moved by the odometry increment (x, y, theta in the robot's frame), its position variance
        grown by the motion's (m^2)."""
        if len(self):
            self.poses = np.atleast_2d(compose(self.poses, increment))
            self.variance = self.variance + variance

    def keep(self, alive: np.ndarray) -> None:
        """Only the hypotheses where `alive` (a place in a wall is impossible): the belief in the others goes to
        `elsewhere` (the robot is somewhere, but not at a place followed), not to the places left."""
        if (~alive).any():
            self.elsewhere = float(np.logaddexp(self.elsewhere, np.logaddexp.reduce(self.evidence[~alive])))
        self._select(alive)
        self._rank()

    def find(self, poses: np.ndarray) -> np.ndarray:
        """(C,) the hypothesis each pose is (within MERGE_DISTANCE and MERGE_ANGLE), -1 where none."""
        return place_index(poses, self.poses)

    def merge(self) -> None:
        """Hypotheses that have come within MERGE_DISTANCE and MERGE_ANGLE of a stronger one (both fitted to the
        same scan) are that place: the stronger is kept, with its own evidence (one place's evidence is not two)."""
        keep = np.ones(len(self), dtype=bool)
        for i in range(len(self)):
            if not keep[i]:
                continue
            later = np.arange(i + 1, len(self))
            near = (np.hypot(*(self.poses[later, :2] - self.poses[i, :2]).T) <= MERGE_DISTANCE) & (
                np.abs(wrap_angle(self.poses[later, 2] - self.poses[i, 2])) <= MERGE_ANGLE
            )
            keep[later[near]] = False
            for absorbed in later[near]:
                self._absorbed[int(self.ids[absorbed])] = int(self.ids[i])
        self._select(keep)

    def index_of(self, identity: int | None) -> int:
        """The index of the place with this identity (`ids`), or of the place it merged into; -1 if it is no longer
        followed (or None)."""
        if identity is None:
            return -1
        # every change of the rows (_select) leaves each merged identity pointing at a place followed
        found = np.flatnonzero(self.ids == self._absorbed.get(identity, identity))
        return int(found[0]) if len(found) else -1

    def _select(self, rows: np.ndarray) -> None:
        """Only these rows (a mask or indices, in that order) of every per-place array; a merged place's identity
        stays resolvable (index_of) only while the place it merged into is followed."""
        self.poses, self.evidence, self.variance = self.poses[rows], self.evidence[rows], self.variance[rows]
        self.ids = self.ids[rows]
        alive = set(self.ids.tolist())
        resolved = {}
        for old, new in self._absorbed.items():
            for _ in range(len(self._absorbed)):  # a chain of merges, each into a place followed when it merged
                if new in alive or new not in self._absorbed:
                    break
                new = self._absorbed[new]
            if new in alive:
                resolved[old] = new
        self._absorbed = resolved

    def reanchor(self, index: int, pose: np.ndarray) -> None:
        """Hypothesis `index` is at `pose` now (its cluster's mean, fitted by the latest scan)."""
        self.poses[index] = pose

    def add(self, poses: np.ndarray, window_gain: np.ndarray) -> None:
        """New hypotheses at `poses`, each with the evidence of the strongest one plus window_gain[i]: what the
        recent scans say of the new place against the strongest (window_gain[i] alone when there is none)."""
        poses = np.atleast_2d(poses).reshape(-1, 3)
        if not len(poses):
            return
        base = float(self.evidence.max()) if len(self) else 0.0
        self.poses = np.vstack([self.poses, poses])
        self.evidence = np.concatenate([self.evidence, base + np.asarray(window_gain, float)])
        self.variance = np.concatenate([self.variance, np.zeros(len(poses))])
        self.ids = np.concatenate([self.ids, self._next_id + np.arange(len(poses), dtype=np.int64)])
        self._next_id += len(poses)
        self._rank()

    def observe(self, log_likelihood: np.ndarray, elsewhere: float) -> None:
        """Each hypothesis's evidence grows by the data's (weighted) log-likelihood at its pose, `elsewhere`'s by
        the data's marginal log-likelihood over the map."""
        if len(self):
            self.evidence = self.evidence + np.nan_to_num(np.asarray(log_likelihood, float), nan=-np.inf, neginf=-1e9)
            self.elsewhere += float(elsewhere) if np.isfinite(elsewhere) else 0.0
            self._rank()

    def probabilities(self) -> np.ndarray:
        """(H,) the posterior of each hypothesis, heaviest first (they sum to 1 - P(elsewhere))."""
        if not len(self):
            return np.zeros(0)
        p = np.exp(np.append(self.evidence, self.elsewhere) - max(self.evidence.max(), self.elsewhere))
        return p[:-1] / p.sum()

    def _rank(self) -> None:
        """Heaviest first, the evidence (elsewhere's too, above as below) within MAX_LOG_ODDS of the best place's, at
        most MAX_HYPOTHESES."""
        self._select(np.argsort(-self.evidence, kind="stable")[:MAX_HYPOTHESES])
        if len(self):
            best = self.evidence[0]
            self.evidence = np.maximum(self.evidence - best, -MAX_LOG_ODDS)
            self.elsewhere = min(max(self.elsewhere - best, -MAX_LOG_ODDS), MAX_LOG_ODDS)


def place_index(poses: np.ndarray, places: np.ndarray) -> np.ndarray:
    """(C,) the place of `places` (H, 3) each pose is (the nearest within MERGE_DISTANCE and MERGE_ANGLE), -1 where
    none."""
    poses = np.atleast_2d(poses)
    out = np.full(len(poses), -1)
    if len(places) and len(poses):
        _nearest(np.asarray(poses, dtype=float), np.asarray(places, dtype=float), MERGE_DISTANCE, MERGE_ANGLE, out)
    return out


@numba.njit(cache=True, nogil=True)
def _nearest(poses, places, distance, angle, out):
    """out[i]: the nearest place (first of equals) within `angle` in heading of pose i, if within `distance`: one pass,
    no (poses x places) temporaries (the particles are found at every update, several times)."""
    for i in range(poses.shape[0]):
        best = np.inf
        for j in range(places.shape[0]):
            dx, dy = poses[i, 0] - places[j, 0], poses[i, 1] - places[j, 1]
            if abs(dx) > distance or abs(dy) > distance:  # beyond it (most particles from most places): no more
                continue
            near = math.hypot(dx, dy)
            if near <= distance and near < best:
                turn = abs((poses[i, 2] - places[j, 2] + math.pi) % (2.0 * math.pi) - math.pi)
                if turn <= angle:
                    best = near
                    out[i] = j
