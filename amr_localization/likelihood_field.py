"""Likelihood-field measurement model (Thrun et al., table 6.3; AMCL's "likelihood_field").

For a particle at pose x and beam k (range z_k, angle phi_k in the sensor frame),
the beam's end point in the map is

    e_k = sensor(x) + z_k (cos(theta_s + phi_k), sin(theta_s + phi_k))

and, with d_k the distance from e_k to the nearest occupied cell (clipped at
laser_likelihood_max_dist; end points off the map count as that far),

    p(z_k | x) = z_hit N(d_k; 0, sigma_hit) + z_rand / range_max
    log p(z | x) = sum_k log p(z_k | x)

The per-cell log p is a lookup table built once per map (distance transform,
then the formula above), so an update is one compiled pass over the
(particles x beams) end points and one gather each: no ray casting. The table
has a one-cell border holding the far value, and end points are clipped onto it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from amr_localization.distance_field import DistanceField
from amr_localization.errors import LocalizationError
from amr_localization.helper_threads import submit
from amr_localization.scan_beams import Beams
from amr_localization.sensor_mount import SensorMount


@dataclass(frozen=True)
class LikelihoodFieldParams:
    sigma_hit: float = 0.05
    """m, spread of a hit around the nearest wall."""
    z_hit: float = 0.9
    z_rand: float = 0.1
    max_dist: float = 2.0
    """m, laser_likelihood_max_dist: distances are clipped here."""

    def __post_init__(self) -> None:
        for name in ("sigma_hit", "max_dist"):
            value = getattr(self, name)
            if not math.isfinite(value) or value <= 0.0:
                raise LocalizationError(f"{name}: must be a positive number, got {value!r}")
        for name in ("z_hit", "z_rand"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0.0:
                raise LocalizationError(f"{name}: must be a number >= 0, got {value!r}")
        if self.z_hit + self.z_rand <= 0.0:
            raise LocalizationError("z_hit + z_rand: must be positive")


class LikelihoodField:
    """log p(scan | pose) for many poses at once."""

    def __init__(
        self, field: DistanceField, params: LikelihoodFieldParams, mount: SensorMount, range_max: float
    ) -> None:
        if not math.isfinite(range_max) or range_max <= 0.0:
            raise LocalizationError(f"range_max: must be a positive number, got {range_max!r}")
        self.params = params
        self.mount = mount
        grid = field.grid
        self._resolution = grid.resolution
        self._origin = grid.origin[:2]
        distance = np.minimum(np.pad(field.distances, 1, constant_values=np.inf), params.max_dist)
        sigma = params.sigma_hit
        density = params.z_hit * np.exp(-0.5 * (distance / sigma) ** 2) / (sigma * math.sqrt(2.0 * math.pi))
        self._table = np.log(density + params.z_rand / range_max).astype(np.float32).ravel()
        self._shape = distance.shape  # (rows + 2, cols + 2)
        # for the free-path check: distance in cells to the nearest occupied cell (the border counts as free)
        cells = np.pad(field.distances, 1, constant_values=np.inf) / grid.resolution
        self._cells = np.minimum(cells, 1e6).astype(np.float32).ravel()
        # a beam through a wall scores as a random reading: the table's floor (a cell far from every wall) as stored
        self._see_through = float(self._table.min()) if params.z_rand > 0.0 else -30.0
        self._range_cells = range_max / grid.resolution + 2.0  # no beam's path is longer

    def log_likelihood(self, particles: np.ndarray, beams: Beams, weights: np.ndarray | None = None) -> np.ndarray:
        """(N,) sum over the returned beams of w_k log p(z_k | particle) (w_k = 1 without `weights`)."""
        use = beams.returned
        if not use.any():
            return np.zeros(len(particles))
        ranges = beams.ranges[use] / self._resolution
        angles = beams.angles[use]
        beam_weights = np.ones(len(ranges)) if weights is None else np.asarray(weights, float)[use]
        along = ranges * np.cos(angles)  # beam end points in the sensor frame, in cells
        across = ranges * np.sin(angles)
        sensor = self.mount.sensor_poses(particles)
        # +1: the table's border (the kernel clips end points onto it)
        col0 = (sensor[:, 0] - self._origin[0]) / self._resolution + 1.0
        row0 = (sensor[:, 1] - self._origin[1]) / self._resolution + 1.0
        out = np.empty(len(particles))
        rows, cols = self._shape
        arguments = (col0, row0, np.cos(sensor[:, 2]), np.sin(sensor[:, 2]))

        def summed(part: slice) -> None:
            _sum_log_likelihood(
                self._table, rows, cols, *(a[part] for a in arguments), along, across, beam_weights, out[part]
            )

        # each particle's sum is its own (the same beams in the same order): thousands of particles are summed in two
        # halves side by side, the first on a helper thread (the kernel runs without the GIL); the same numbers
        if len(particles) < SPLIT_PARTICLES:
            summed(slice(None))
            return out
        half = len(particles) // 2
        first = submit(summed, slice(0, half))
        try:
            summed(slice(half, None))
        finally:
            first.result()
        return out

    def log_likelihood_free_path(
        self, particles: np.ndarray, beams: Beams, margin: float, per_beam: bool = False
    ) -> np.ndarray:
        """(N,) log_likelihood, except that a beam whose path from the sensor to `margin` m short of its end
        point goes through a wall scores as a random reading (log z_rand / range_max) at best. A beam without
        a return (beams selected with keep_no_return) scores 0, as in log_likelihood, unless a wall stands
        on its path within range_max - margin: then it scores that too (a wall in range returns).
        per_beam: (N, beams) terms instead of their sums.

        The likelihood field alone only asks how near a wall each end point lies, so a beam seen through a
        doorway, whose end point lands near a wall behind it, scores as well at a place where a wall stands
        in the doorway. This is the beam model's free-path knowledge at the cost of a sphere trace per beam
        on the distance field (steps of the distance to the nearest wall, a few per metre in a room):
        meant for a few poses, not for thousands of particles.
        """
        terms = self.best_free_path(particles, np.zeros((1, 3)), beams, margin)
        return terms if per_beam else terms.sum(axis=1)

    def fixed_poses(self, poses: np.ndarray, nudges: np.ndarray) -> FixedPoses:
        """Poses scored by best_free_path again and again (FixedPoses): their paths traced once."""
        return FixedPoses(self, poses, nudges)

    def best_free_path(
        self, poses: np.ndarray, nudges: np.ndarray, beams: Beams, margin: float, exits: Exits | None = None
    ) -> np.ndarray:
        """(H, beams): for each pose and beam, the best of log_likelihood_free_path's per-beam terms over the pose
        moved by each of the (M, 3) `nudges` (x, y, theta offsets added to the pose): a beam reads as going through
        a wall only where it does so from every nudged pose.

        The same maximum as tracing every nudged beam, without doing so: a beam's candidates are taken in order
        of their end point's term, and the first whose path is free ends the search (no later one can score more);
        a blocked one scores min(term, see-through) and the next is traced only where it could score more. Where
        the beam is free, one trace instead of M. Nudges in runs of one heading turn the beam once per run.
        exits: where each nudged beam of these poses goes through a wall and out (FixedPoses), read and filled in
        instead of traced."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        nudges = np.asarray(nudges, dtype=float).reshape(-1, 3)
        out = np.zeros((len(poses), beams.ranges.size))
        if beams.ranges.size == 0 or not len(poses):
            return out
        ranges = np.where(beams.returned, beams.ranges, beams.range_max) / self._resolution
        sensor = self.mount.sensor_poses((poses[:, None, :] + nudges[None, :, :]).reshape(-1, 3))
        shape = (len(poses), len(nudges))
        col0 = ((sensor[:, 0] - self._origin[0]) / self._resolution + 1.0).reshape(shape)
        row0 = ((sensor[:, 1] - self._origin[1]) / self._resolution + 1.0).reshape(shape)
        rows, cols = self._shape
        _best_free_path_terms(
            self._table,
            self._cells,
            rows,
            cols,
            col0,
            row0,
            np.ascontiguousarray(sensor[:, 2]).reshape(shape),  # one compiled variant (one pose and nudge: C)
            beams.angles,
            ranges,
            beams.returned,
            margin / self._resolution,
            self._see_through,
            out,
            _NO_EXITS if exits is None else exits.table,
            _NO_COLUMNS if exits is None else exits.columns,
            self._range_cells,
        )
        return out


class Exits(NamedTuple):
    """Where nudged beams first go through a wall and out (cells from the sensor; inf: never within range_max; NaN:
    not traced yet), table[pose, columns[k], nudge] for beam k."""

    table: np.ndarray
    columns: np.ndarray


class FixedPoses:
    """Poses scored again and again with the same nudges (the particle filter's `elsewhere` poses, drawn once): the
    first exit of each nudged beam through a wall, kept per beam of the scan (its angle in the sensor frame) as it is
    first traced. A path is blocked before a length exactly where its first exit lies before it, so the score is the
    one best_free_path gives, while a beam seen before costs a look-up where it cost up to a trace per nudge (poses
    drawn at random see through walls on most beams: each nudged beam is traced to a wall)."""

    def __init__(self, field: LikelihoodField, poses: np.ndarray, nudges: np.ndarray) -> None:
        self.field = field
        self.poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        self.nudges = np.asarray(nudges, dtype=float).reshape(-1, 3)
        self._columns: dict[int, int] = {}
        self._table = np.empty((len(self.poses), 0, len(self.nudges)))

    def best_free_path(self, beams: Beams, margin: float) -> np.ndarray:
        """(H, beams): LikelihoodField.best_free_path of these poses."""
        keys = np.round(beams.angles * ANGLE_KEYS).astype(np.int64).tolist()
        new = [key for key in dict.fromkeys(keys) if key not in self._columns]
        if new:
            for key in new:
                self._columns[key] = len(self._columns)
            grown = np.full((len(self.poses), len(self._columns), len(self.nudges)), np.nan)
            grown[:, : self._table.shape[1]] = self._table
            self._table = grown
        columns = np.array([self._columns[key] for key in keys], dtype=np.int64)
        return self.field.best_free_path(self.poses, self.nudges, beams, margin, Exits(self._table, columns))


SPLIT_PARTICLES = 2000
"""particles from which log_likelihood sums them in two halves side by side (a global localization's or a withdrawn
stretch's thousands: 1.2-1.4 ms a stage at 5,000 x 60 beams; a hundred cost less than the hand-off)."""
ANGLE_KEYS = 1e7
"""beams are told apart by their angle in the sensor frame to 1e-7 rad (a scan's beams lie far more apart)."""
_NO_EXITS = np.empty((0, 0, 0))
_NO_COLUMNS = np.empty(0, dtype=np.int64)


@numba.njit(cache=True, nogil=True)
def _sum_log_likelihood(table, rows, cols, col0, row0, cos_theta, sin_theta, along, across, weights, out):
    """out[i] = sum_k weights[k] table[cell of beam k's end point for particle i]: one pass, no (N, K) temporaries.

    Compiled: the numpy version of the same sum built four (N, K) arrays and was bound by memory
    (5,000 x 60: 4.3 ms against about 1 ms here).
    """
    for i in range(col0.shape[0]):
        c, s, x, y = cos_theta[i], sin_theta[i], col0[i], row0[i]
        total = 0.0
        for k in range(along.shape[0]):
            col = min(max(x + c * along[k] - s * across[k], 0.0), cols - 1.0)
            row = min(max(y + s * along[k] + c * across[k], 0.0), rows - 1.0)
            total += weights[k] * table[int(row) * cols + int(col)]
        out[i] = total


@numba.njit(cache=True, nogil=True)
def _exit(cells, rows, cols, x, y, c, s, free):
    """Where (cells from (x, y)) the beam from (x, y) along (c, s) first goes through an occupied cell and out; inf
    where it does not before `free` cells: the path to `free` is blocked exactly where the result is below `free`.

    Sphere tracing in cells: from the sensor, step along the beam by the distance to the nearest occupied cell
    centre minus 1.5 cells (a point and an occupied cell are each up to half a diagonal from their centres), at
    least half a cell. The path is blocked where it has gone through an occupied cell and come out 2 cells clear
    of any wall before `free`: a beam that only grazes a wall's surface near its end point (at a shallow angle,
    margin along the beam is little margin from the wall) is not blocked. Occupied cells the trace starts in (a
    sensor a cell into a wall: the pose or the map a cell off) do not count.
    """
    t = 0.0
    inside = False
    clear = False
    while t < free:
        col = x + c * t
        row = y + s * t
        if col < 0.0 or row < 0.0 or col >= cols or row >= rows:
            return math.inf
        distance = cells[int(row) * cols + int(col)]
        clear = clear or distance >= 1.0
        if distance == 0.0 and clear:
            inside = True
        elif inside and distance >= 2.0:  # through a wall and out on its other side
            return t
        t += max(distance - 1.5, 0.5)
    return math.inf


@numba.njit(cache=True, nogil=True)
def _best_free_path_terms(
    table,
    cells,
    rows,
    cols,
    col0,
    row0,
    theta,
    angles,
    ranges,
    returned,
    margin,
    see_through,
    out,
    exits,
    columns,
    range_cells,
):
    """out[h, k]: the best over nudges n of beam k's likelihood-field term from sensor pose (col0, row0, theta)[h, n],
    capped at see_through (the table's floor) where that beam's path is blocked (_exit) before range - margin.
    Candidates are traced in decreasing order of their term, until one is free, is at the floor (capped or not, the
    same), or none left could score more than the best so far. exits (unless empty): each nudged beam's exit, read
    where known, else traced to range_cells and kept; the same maximum, taken in one pass."""
    memo = exits.shape[1] > 0
    nudges = col0.shape[1]
    value = np.empty(nudges)
    done = np.empty(nudges, dtype=np.bool_)
    cos_n = np.empty(nudges)
    sin_n = np.empty(nudges)
    for h in range(col0.shape[0]):
        for k in range(angles.shape[0]):
            for n in range(nudges):
                if n == 0 or theta[h, n] != theta[h, n - 1]:
                    cos_n[n], sin_n[n] = math.cos(theta[h, n] + angles[k]), math.sin(theta[h, n] + angles[k])
                else:
                    cos_n[n], sin_n[n] = cos_n[n - 1], sin_n[n - 1]
                value[n] = 0.0
                if returned[k]:
                    c, s = cos_n[n], sin_n[n]
                    col = min(max(col0[h, n] + c * ranges[k], 0.0), cols - 1.0)
                    row = min(max(row0[h, n] + s * ranges[k], 0.0), rows - 1.0)
                    value[n] = table[int(row) * cols + int(col)]
                done[n] = False
            best = -np.inf
            free = ranges[k] - margin
            if memo:  # exits known or kept once traced: each nudge in turn, read where it could score more
                for n in range(nudges):
                    term = value[n]
                    if term <= best:
                        continue
                    if term > see_through:
                        out_at = exits[h, columns[k], n]
                        if math.isnan(out_at):
                            out_at = _exit(cells, rows, cols, col0[h, n], row0[h, n], cos_n[n], sin_n[n], range_cells)
                            exits[h, columns[k], n] = out_at
                        if out_at < free:
                            term = see_through
                    best = max(best, term)
                out[h, k] = best
                continue
            while True:
                pick, top = -1, best
                for n in range(nudges):
                    if not done[n] and value[n] > top:
                        pick, top = n, value[n]
                if pick < 0:
                    break
                done[pick] = True
                c, s = cos_n[pick], sin_n[pick]
                if top <= see_through:  # at the floor, blocked or not scores the same: no trace
                    best = top
                    break
                if _exit(cells, rows, cols, col0[h, pick], row0[h, pick], c, s, free) < free:
                    best = max(best, see_through)
                else:
                    best = top
                    break
            out[h, k] = best
