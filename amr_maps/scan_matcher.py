"""Correlative scan-to-map matching: multi-resolution branch and bound (Olson, ICRA 2009; Hess et al., ICRA 2016).

A scan (points in the robot frame) is scored at a pose by the mean, over its points, of a lookup table
(`ScoreMap`: 0..1 per cell, 0 off the table). The poses searched form a lattice: translations in whole
cells, rotations in steps of `angular_step` (by default the step that moves the farthest point by one
cell). The best lattice pose is found exactly by branch and bound over a pyramid of max-pooled tables,
as Cartographer's FastCorrelativeScanMatcher2D: level k holds, at each cell, the maximum of the table over
the 2^k x 2^k cells starting there, so the mean lookup at level k of a block of 2^k x 2^k translations is an
upper bound of every pose in the block. Blocks are scored coarse to fine, best first (depth first), and a
block whose bound cannot beat the best found is never opened.

- `CorrelativeMatcher.match`: the best pose in a window around a prior (scan to map, or scan to submap),
  then a sub-cell refinement (Gauss-Newton on the bilinearly interpolated table, as Hector SLAM) and a
  covariance (Olson's: the moments of the score surface around the peak, weights (score / best)^N).
- `GlobalSearch` (and `CorrelativeMatcher.search`, one call of it): the `count` best well-separated poses
  over a whole map (place recognition), by a resumable budgeted branch and bound: `step(max_nodes)`
  continues where the last call stopped and returns the best found so far.

Tables are stored as uint16 (score * 65535), the sums of a branch and bound as integers: bounds compare
exactly, and a pyramid of a 2000 x 2000 map with 8 levels takes 64 MB.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numba
import numpy as np
from scipy import ndimage

from amr_maps.occupancy_grid import OccupancyGrid

QUANTUM = 65535
"""A table cell's score s is stored as round(s * QUANTUM) (uint16)."""
MAX_LEVELS = 12
FIELD_REACH = 6.0
"""sigmas: a point cloud's field (ScoreMap.from_points) is computed this far from its points (beyond, exp(-18) = 1.5e-8
of a point's score: 0)."""
_FAR = 1 << 30
"""Cell indices are clipped to +-_FAR (points thousands of km away still score 0, without overflow)."""


@dataclass(frozen=True)
class ScoreMap:
    """The lookup table of the matcher: `table[row, col]` in 0..1, row 0 the lowest y, col 0 the lowest x
    (amr_maps.occupancy_grid's layout), `origin` (x, y) of cell (0, 0)'s lower-left corner. `free`: the cells a
    robot may stand in (the default candidates of a global search)."""

    table: np.ndarray
    resolution: float
    origin: tuple[float, float]
    free: np.ndarray | None = None

    def __post_init__(self) -> None:
        table = np.asarray(self.table, dtype=np.float32)
        if table.ndim != 2 or table.size == 0:
            raise ValueError(f"score map: table must be a non-empty 2D array, got shape {table.shape}")
        if not np.all(np.isfinite(table)) or table.min() < 0.0 or table.max() > 1.0:
            raise ValueError("score map: table values must be finite and in 0..1")
        resolution = float(self.resolution)
        if not math.isfinite(resolution) or resolution <= 0.0:
            raise ValueError(f"score map: resolution must be a positive number of m/cell, got {self.resolution!r}")
        if len(self.origin) < 2 or not all(math.isfinite(float(v)) for v in self.origin[:2]):
            raise ValueError(f"score map: origin must be finite (x, y), got {self.origin!r}")
        free = np.ones(table.shape, dtype=bool) if self.free is None else np.asarray(self.free, dtype=bool)
        if free.shape != table.shape:
            raise ValueError(f"score map: free mask shape {free.shape} differs from the table's {table.shape}")
        object.__setattr__(self, "table", table)
        object.__setattr__(self, "resolution", resolution)
        object.__setattr__(self, "origin", (float(self.origin[0]), float(self.origin[1])))
        object.__setattr__(self, "free", free)

    @classmethod
    def from_probability(cls, prob: np.ndarray, resolution: float, origin, free_below: float = 0.35) -> ScoreMap:
        """The table is the occupancy probability itself (Cartographer's probability grid); cells below
        `free_below` are the free ones (a log-odds map's unknown cells hold 0.5)."""
        prob = np.clip(np.nan_to_num(np.asarray(prob, dtype=np.float32), nan=0.0), 0.0, 1.0)
        return cls(prob, resolution, (float(origin[0]), float(origin[1])), prob < free_below)

    @classmethod
    def from_occupancy(
        cls, grid: OccupancyGrid, sigma: float = 0.05, unknown: float = 0.05, occupied_threshold: int = 65
    ) -> ScoreMap:
        """exp(-d^2 / (2 sigma^2)) with d the distance (m) from a cell's centre to the nearest occupied cell's
        (a likelihood field); unknown cells score at least `unknown` (a small constant: they may hide a wall).
        No occupied cell at all: every cell scores 0 (unknown ones `unknown`)."""
        if not math.isfinite(sigma) or sigma <= 0.0:
            raise ValueError(f"score map: sigma must be a positive number of m, got {sigma!r}")
        if not math.isfinite(unknown) or not 0.0 <= unknown <= 1.0:
            raise ValueError(f"score map: unknown must be a score in 0..1, got {unknown!r}")
        occupied = grid.occupied(occupied_threshold)
        if occupied.any():
            distance = ndimage.distance_transform_edt(~occupied) * grid.resolution
            table = np.exp(-0.5 * (distance / sigma) ** 2)
        else:
            table = np.zeros(occupied.shape)
        table = np.where(grid.data < 0, np.maximum(table, unknown), table)
        return cls(table.astype(np.float32), grid.resolution, grid.origin[:2], grid.free())

    @classmethod
    def from_points(
        cls,
        points: np.ndarray,
        resolution: float,
        sigma: float,
        pad: float,
        cover: np.ndarray | None = None,
        to_points: bool = False,
    ) -> ScoreMap:
        """The likelihood field of a point cloud (a scan's end points: Olson's rasterized scan), on cells of
        `resolution` covering the points, and the `cover` points if given (not rasterized), and `pad` m around them.
        A cell's distance is to the nearest cell holding a point (its centre); `to_points`: to the mean of that
        cell's points instead (up to half a cell nearer the truth: the lattice's scores and their curvature see the
        walls where they are, as a scan matcher's front end wants; every cell a candidate)."""
        points = _finite_points(points)
        extent = points if cover is None else np.vstack([points, _finite_points(cover)])
        if not len(extent):
            raise ValueError("score map: no finite point to rasterize or cover")
        if not math.isfinite(pad) or pad < 0.0:
            raise ValueError(f"score map: pad must be a number >= 0 m, got {pad!r}")
        low = np.floor((extent.min(axis=0) - pad) / resolution) * resolution
        shape = np.ceil((extent.max(axis=0) + pad - low) / resolution).astype(int) + 1
        cells = np.floor((points - low) / resolution).astype(int)
        if to_points:
            return cls(_point_table(points, cells, low, shape, resolution, sigma), resolution, (low[0], low[1]))
        occupied = np.zeros((shape[1], shape[0]), dtype=bool)
        occupied[cells[:, 1], cells[:, 0]] = True
        # from_occupancy's field, cell for cell, within FIELD_REACH sigmas of a point (0 beyond, where it is below
        # exp(-FIELD_REACH^2 / 2)): stamped around the points' cells, not a distance transform of the whole box a
        # scan's far beams span (a 30 m scan: 1.6 million cells on 5 cm, 3.4 ms; the stamps, 0.1 ms)
        reach = int(math.ceil(FIELD_REACH * sigma / resolution))
        offsets = np.arange(-reach, reach + 1)
        steps = np.hypot(offsets[:, None], offsets[None, :])
        stamp = np.where(steps <= reach, np.exp(-0.5 * (steps * resolution / sigma) ** 2), 0.0)
        rows, cols = np.nonzero(occupied)
        table = _stamped_field(rows, cols, occupied.shape, stamp)
        return cls(table.astype(np.float32), resolution, (float(low[0]), float(low[1])), ~occupied)

    @property
    def shape(self) -> tuple[int, int]:
        return int(self.table.shape[0]), int(self.table.shape[1])


@dataclass(frozen=True)
class Match:
    """A pose (x, y, theta) of the robot frame in the map frame and its score: the mean lookup over the
    scan's points, 0..1 (bilinear after refinement, the cell lookup otherwise). exhaustive: the search was
    complete (the pose is the best of its lattice). nodes: B&B nodes scored to find it (the whole search's
    count for a global search). covariance: 3x3 in (m, m, rad), Olson's, never below the lattice's
    quantization (res^2 / 12, res^2 / 12, step^2 / 12)."""

    pose: np.ndarray
    score: float
    exhaustive: bool
    nodes: int
    covariance: np.ndarray = field(default_factory=lambda: np.diag([np.inf, np.inf, np.inf]))


class WindowLattice(NamedTuple):
    """The poses of a windowed lattice and their scores (CorrelativeMatcher.window_lattice): pose [a, y, x] is
    (prior x + offsets[x], prior y + offsets[y], prior theta + turns[a]), its score totals[a, y, x] / denominator
    (the mean cell lookup: the sum over the points of the table's integers, over their count times QUANTUM)."""

    prior: np.ndarray
    offsets: np.ndarray
    """(S,) m: the translations' offsets, in x and in y alike."""
    turns: np.ndarray
    """(A,) rad: the headings' offsets."""
    totals: np.ndarray
    """(A, S, S) int64."""
    denominator: float


def default_angular_step(points: np.ndarray, resolution: float) -> float:
    """The rotation that moves the farthest point of the scan by one cell (Cartographer's
    acos(1 - r^2 / (2 d^2))), at most 0.2 rad."""
    return _angular_step(_finite_points(points), resolution)


def _angular_step(points: np.ndarray, resolution: float) -> float:
    """default_angular_step of (K, 2) finite points."""
    farthest = float(np.max(np.hypot(points[:, 0], points[:, 1]))) if len(points) else 0.0
    if farthest <= resolution:
        return 0.2
    return min(0.2, math.acos(1.0 - resolution * resolution / (2.0 * farthest * farthest)))


class CorrelativeMatcher:
    """Branch-and-bound correlative matching against one ScoreMap (build once per map: the pyramid is
    `levels` tables of the map's size, uint16)."""

    def __init__(self, score_map: ScoreMap, levels: int | None = None) -> None:
        rows, cols = score_map.shape
        if levels is None:  # top blocks of about 1/16 of the map's larger side, 2..128 cells
            levels = min(8, max(2, math.ceil(math.log2(max(rows, cols))) - 3))
        if not isinstance(levels, (int, np.integer)) or not 1 <= levels <= MAX_LEVELS:
            raise ValueError(f"correlative matcher: levels must be an integer in 1..{MAX_LEVELS}, got {levels!r}")
        self.score_map = score_map
        self.levels = int(levels)
        self.resolution = score_map.resolution
        self.origin = score_map.origin
        self.pad = (1 << (self.levels - 1)) - 1
        base = np.zeros((rows + self.pad, cols + self.pad), dtype=np.uint16)
        base[self.pad :, self.pad :] = np.rint(score_map.table * QUANTUM).astype(np.uint16)
        self.pyramid = _max_pyramid(base, self.levels)
        self._free_pyramid: np.ndarray | None = None

    # -- scores ------------------------------------------------------------------------------------------

    def score(self, points: np.ndarray, pose) -> float:
        """Mean cell lookup (the lattice's score) of the points at pose; points off the table score 0."""
        points = _finite_points(points)
        if len(points) == 0:
            return 0.0
        rows, cols = _cells(
            points, float(pose[0]), float(pose[1]), np.array([float(pose[2])]), self.origin, self.resolution
        )
        total = _node_total(self.pyramid, 0, self.pad, rows, cols, 0, 0, 0)
        return total / (len(points) * QUANTUM)

    def score_interpolated(self, points: np.ndarray, pose) -> float:
        """Mean bilinear interpolation of the table (cell centres as nodes) at the points moved by pose."""
        points = _finite_points(points)
        if len(points) == 0:
            return 0.0
        values, _, _ = self._bilinear(points, np.asarray(pose, dtype=float))
        return float(values.mean())

    # -- local matching ------------------------------------------------------------------------------------

    def match(
        self,
        points: np.ndarray,
        prior,
        linear_window: float,
        angular_window: float,
        angular_step: float | None = None,
        refine: bool = True,
        max_nodes: int | None = None,
        covariance_cells: int = 4,
    ) -> Match:
        """The best pose of the lattice (whole cells, angular steps) within +-linear_window (m, in x and in
        y) and +-angular_window (rad) of prior, by branch and bound (exact unless max_nodes runs out: then
        exhaustive is False), refined below the cell when `refine`; its covariance from +-covariance_cells around the
        peak (0: the lattice's quantization only, not computed). No finite point: the prior, score 0."""
        search = WindowMatch(self, points, prior, linear_window, angular_window, angular_step)
        search.advance(np.iinfo(np.int64).max if max_nodes is None else max_nodes)
        return search.result(refine, covariance_cells)

    def window_scores(
        self, points: np.ndarray, prior, linear_window: float, angular_window: float, angular_step: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Every pose of the lattice within +-linear_window (m, in x and y) and +-angular_window (rad) of prior, and
        its score (the mean cell lookup, 0..1): (M, 3) poses and (M,) scores; for a posterior over the window (the
        match's score as a likelihood, times a prior) where the best pose alone is not enough."""
        lattice = self.window_lattice(points, prior, linear_window, angular_window, angular_step)
        prior = lattice.prior
        da, dy, dx = np.meshgrid(lattice.turns, lattice.offsets, lattice.offsets, indexing="ij")
        poses = np.stack([prior[0] + dx.ravel(), prior[1] + dy.ravel(), prior[2] + da.ravel()], axis=1)
        return poses, lattice.totals.ravel() / lattice.denominator

    def window_lattice(
        self, points: np.ndarray, prior, linear_window: float, angular_window: float, angular_step: float | None = None
    ) -> WindowLattice:
        """window_scores' lattice without its poses spelled out (WindowLattice): for a pass over tens of thousands of
        poses that needs their scores and offsets, not (M, 3) and (M,) arrays of them."""
        points = _finite_points(points)
        prior = np.asarray(prior, dtype=float).reshape(3)
        res = self.resolution
        step = self._step(points, angular_step)
        reach = int(math.ceil(linear_window / res - 1e-9))
        turns = int(math.ceil(angular_window / step - 1e-9))
        offsets = np.arange(-reach, reach + 1)
        thetas = prior[2] + step * np.arange(-turns, turns + 1)
        size = 2 * reach + 1
        totals = np.zeros((len(thetas), size, size), dtype=np.int64)
        if len(points):
            rows, cols = _cells(points, prior[0] - reach * res, prior[1] - reach * res, thetas, self.origin, res)
            _lattice_totals(self.pyramid, self.pad, rows, cols, totals)
        return WindowLattice(prior, offsets * res, thetas - prior[2], totals, float(max(len(points), 1) * QUANTUM))

    # -- global search ---------------------------------------------------------------------------------------

    def search(
        self,
        points: np.ndarray,
        candidates_region: np.ndarray | None = None,
        angular_step: float | None = None,
        count: int = 5,
        min_score: float = 0.0,
        max_nodes: int = 200_000,
        min_separation: float = 0.5,
        min_angle_separation: float = 0.5,
        refine: bool = True,
        max_seconds: float | None = None,
    ) -> list[Match]:
        """The `count` best well-separated poses over the map (robot in a cell of candidates_region; None:
        the score map's free cells), best first: one GlobalSearch step of max_nodes scored nodes."""
        searcher = GlobalSearch(
            self, points, candidates_region, angular_step, count, min_score, min_separation, min_angle_separation
        )
        return searcher.step(max_nodes, refine=refine, max_seconds=max_seconds)

    # -- internals ---------------------------------------------------------------------------------------

    def _step(self, points: np.ndarray, angular_step: float | None) -> float:
        if angular_step is None:
            return _angular_step(points, self.resolution)  # every caller's points are finite already
        if not math.isfinite(angular_step) or angular_step <= 0.0:
            raise ValueError(f"angular_step must be a positive number of rad, got {angular_step!r}")
        return float(angular_step)

    def free_pyramid(self) -> np.ndarray:
        """The max-pooled pyramid of the score map's free mask (cached): the default global candidates."""
        if self._free_pyramid is None:
            self._free_pyramid = _max_pyramid(self.score_map.free.astype(np.uint8), self.levels)
        return self._free_pyramid

    def _finish(
        self,
        points: np.ndarray,
        pose: np.ndarray,
        total: int,
        step: float,
        exhaustive: bool,
        nodes: int,
        refine: bool,
        covariance_cells: int,
    ) -> Match:
        score = total / (len(points) * QUANTUM)
        # covariance_cells 0: no covariance wanted (the lattice's quantization stands in for it)
        covariance = (
            self._covariance(points, pose, step, covariance_cells)
            if covariance_cells > 0
            else _floor_covariance(self.resolution, step)
        )
        if refine:
            pose, score = self._refine(points, pose, step)
        return Match(pose, float(score), bool(exhaustive), int(nodes), covariance)

    def _bilinear(self, points: np.ndarray, pose: np.ndarray):
        """Bilinear table values at the points moved by pose, and their gradients (per m) in x and y."""
        c, s = math.cos(pose[2]), math.sin(pose[2])
        wx = pose[0] + c * points[:, 0] - s * points[:, 1]
        wy = pose[1] + s * points[:, 0] + c * points[:, 1]
        return _bilinear(
            self.score_map.table,
            (wx - self.origin[0]) / self.resolution - 0.5,
            (wy - self.origin[1]) / self.resolution - 0.5,
            1.0 / self.resolution,
        )

    def _refine(self, points: np.ndarray, pose: np.ndarray, step: float, iterations: int = 15, reach: float = 2.0):
        """Gauss-Newton on sum (1 - M(T(pose) p))^2 over the bilinear table M (Hector SLAM's scan matching),
        each step kept only if the mean score grows, the pose kept within `reach` cells and angular steps of
        the lattice's (the lattice's best may sit anywhere on a plateau of thick walls: a cell or two off)."""
        refined = np.array(pose, dtype=float)
        best = _refine_kernel(
            self.score_map.table,
            np.ascontiguousarray(points[:, 0], dtype=np.float64),
            np.ascontiguousarray(points[:, 1], dtype=np.float64),
            float(self.origin[0]),
            float(self.origin[1]),
            float(self.resolution),
            refined,
            float(step),
            int(iterations),
            float(reach),
        )
        refined[2] = _wrap(refined[2])
        return refined, best

    def _covariance(self, points: np.ndarray, pose: np.ndarray, step: float, cells: int) -> np.ndarray:
        """Olson's covariance: the weighted second moments of the lattice poses within +-cells cells and
        +-cells angular steps of pose, weights (score / best)^N (the scan's likelihood if its points were
        independent), plus the lattice's own quantization."""
        res = self.resolution
        offsets = np.arange(-cells, cells + 1)
        thetas = pose[2] + step * offsets
        rows, cols = _cells(points, pose[0] - cells * res, pose[1] - cells * res, thetas, self.origin, res)
        size = 2 * cells + 1
        totals = np.empty((len(thetas), size, size), dtype=np.int64)
        _lattice_totals(self.pyramid, self.pad, rows, cols, totals)
        best = totals.max()
        if best <= 0:
            return np.diag([(size * res) ** 2 / 12.0, (size * res) ** 2 / 12.0, (size * step) ** 2 / 12.0])
        with np.errstate(divide="ignore"):
            log_weight = len(points) * (np.log(totals.astype(float)) - math.log(best))
        weight = np.exp(log_weight).ravel()
        da, dy, dx = np.meshgrid(offsets * step, offsets * res, offsets * res, indexing="ij")
        samples = np.stack([dx.ravel(), dy.ravel(), da.ravel()], axis=1)
        total = weight.sum()
        mean = weight @ samples / total
        centred = samples - mean
        covariance = (centred * weight[:, None]).T @ centred / total
        return covariance + _floor_covariance(res, step)


class WindowMatch:
    """CorrelativeMatcher.match as a resumable search: `advance(max_nodes)` scores at most that many more branch and
    bound nodes (continuing where the last call stopped), `result()` is the Match that `match` gives with the nodes
    scored so far (the same search: a windowed match spread over several calls, each of bounded work, gives the
    match's answer once `done`). `nodes`: scored so far (each one lookup per point)."""

    def __init__(
        self,
        matcher: CorrelativeMatcher,
        points: np.ndarray,
        prior,
        linear_window: float,
        angular_window: float,
        angular_step: float | None = None,
    ) -> None:
        points, prior = _window_arguments("match", points, prior, linear_window, angular_window)
        self.matcher = matcher
        self.points, self.prior = points, prior
        res = matcher.resolution
        self.step = matcher._step(points, angular_step)
        self._search: _BranchAndBound | None = None
        if len(points) == 0:
            return
        reach = int(math.ceil(linear_window / res - 1e-9))
        turns = int(math.ceil(angular_window / self.step - 1e-9))
        self.thetas = prior[2] + self.step * np.arange(-turns, turns + 1)
        self.x_ref, self.y_ref = prior[0] - reach * res, prior[1] - reach * res
        rows, cols = _cells(points, self.x_ref, self.y_ref, self.thetas, matcher.origin, res)
        size = 2 * reach + 1
        top = min(matcher.levels - 1, max(0, math.ceil(math.log2(size))))
        span = 1 << top
        tops = _top_blocks(len(self.thetas), np.arange(0, size, span, dtype=np.int32))
        self._search = _BranchAndBound(matcher, rows, cols, size, size, tops, top, None, 1, 0, 10**18, 10**9, 0)

    @property
    def done(self) -> bool:
        return self._search is None or self._search.done

    @property
    def nodes(self) -> int:
        return 0 if self._search is None else self._search.nodes

    def advance(self, max_nodes: int) -> None:
        """Score at most max_nodes more nodes (fewer once done)."""
        if self._search is not None:
            self._search.run(int(max_nodes))

    def result(self, refine: bool = True, covariance_cells: int = 4) -> Match:
        """The best pose found so far (exhaustive once done), refined below the cell when `refine`, with its
        covariance from +-covariance_cells around the peak (0: the lattice's quantization); no finite point, or
        nothing scored above 0: the prior, score 0 (see CorrelativeMatcher.match)."""
        res, step = self.matcher.resolution, self.step
        found = [] if self._search is None else self._search.results()
        if not found:  # every pose scored 0 (or the budget ran out before a leaf)
            return Match(self.prior.copy(), 0.0, self.done, self.nodes, _floor_covariance(res, step))
        a, x, y, total = found[0]
        pose = np.array([self.x_ref + x * res, self.y_ref + y * res, float(_wrap(self.thetas[a]))])
        return self.matcher._finish(self.points, pose, total, step, self.done, self.nodes, refine, covariance_cells)


class GlobalSearch:
    """A resumable global branch and bound: the `count` best poses over the whole map, pairwise more than
    min_separation (m) or min_angle_separation (rad) apart, of score >= min_score. Each `step(max_nodes)`
    scores at most max_nodes more nodes (each costs one lookup per point) and returns the best found so
    far; `done` once the search is complete (then the matches are exhaustive: the exact best of the
    lattice). The lattice: robot at the centre of each cell of candidates_region, headings k * step."""

    def __init__(
        self,
        matcher: CorrelativeMatcher,
        points: np.ndarray,
        candidates_region: np.ndarray | None = None,
        angular_step: float | None = None,
        count: int = 5,
        min_score: float = 0.0,
        min_separation: float = 0.5,
        min_angle_separation: float = 0.5,
    ) -> None:
        if not isinstance(count, (int, np.integer)) or count < 1:
            raise ValueError(f"global search: count must be an integer >= 1, got {count!r}")
        if not math.isfinite(min_score) or not 0.0 <= min_score <= 1.0:
            raise ValueError(f"global search: min_score must be in 0..1, got {min_score!r}")
        self.matcher = matcher
        self.points = _finite_points(points)
        res = matcher.resolution
        rows_map, cols_map = matcher.score_map.shape
        step = matcher._step(self.points, angular_step)
        n_angles = max(1, int(math.ceil(2.0 * math.pi / step - 1e-9)))
        self.angular_step = 2.0 * math.pi / n_angles
        self.thetas = self.angular_step * np.arange(n_angles)
        if candidates_region is None:
            region = matcher.free_pyramid()
        else:
            mask = np.asarray(candidates_region, dtype=bool)
            if mask.shape != (rows_map, cols_map):
                raise ValueError(
                    f"global search: candidates_region shape {mask.shape} differs from the map's {(rows_map, cols_map)}"
                )
            region = _max_pyramid(mask.astype(np.uint8), matcher.levels)
        self._x_ref = matcher.origin[0] + 0.5 * res
        self._y_ref = matcher.origin[1] + 0.5 * res
        top = matcher.levels - 1
        span = 1 << top
        by, bx = np.nonzero(region[top][::span, ::span])
        if len(self.points) == 0:
            bx = by = np.zeros(0, dtype=np.int64)
        a = np.repeat(np.arange(n_angles), len(bx))
        tops = np.stack([a, np.tile(bx * span, n_angles), np.tile(by * span, n_angles)], axis=1).astype(np.int32)
        rows, cols = _cells(self.points, self._x_ref, self._y_ref, self.thetas, matcher.origin, res)
        min_total = int(math.ceil(min_score * len(self.points) * QUANTUM - 1e-6))
        sep2 = (min_separation / res) ** 2
        angle_sep = min_angle_separation / self.angular_step
        self._search = _BranchAndBound(
            matcher,
            rows,
            cols,
            cols_map,
            rows_map,
            tops,
            top,
            region,
            count,
            max(min_total, 1),
            sep2,
            angle_sep,
            n_angles,
        )

    @property
    def done(self) -> bool:
        return self._search.done

    @property
    def nodes(self) -> int:
        return self._search.nodes

    def step(self, max_nodes: int = 200_000, refine: bool = True, max_seconds: float | None = None) -> list[Match]:
        """Score up to max_nodes more nodes (and stop after max_seconds, checked every 20,000 nodes), then the
        best matches so far, best first."""
        if max_nodes < 0:
            raise ValueError(f"global search: max_nodes must be >= 0, got {max_nodes!r}")
        if max_seconds is None:
            self.advance(max_nodes)
        else:
            deadline = time.perf_counter() + max_seconds
            left = int(max_nodes)
            while left > 0 and not self.done and time.perf_counter() < deadline:
                before = self._search.nodes
                self._search.run(min(left, 20_000))
                left -= self._search.nodes - before
        return self.matches(refine)

    def advance(self, max_nodes: int) -> None:
        """Score up to max_nodes more nodes, nothing else (step without the matches). The compiled search runs
        without the GIL: a thread may advance a search while others go on, as long as no one else touches this
        search meanwhile."""
        if max_nodes < 0:
            raise ValueError(f"global search: max_nodes must be >= 0, got {max_nodes!r}")
        self._search.run(int(max_nodes))

    def matches(self, refine: bool = True, covariance_cells: int = 4) -> list[Match]:
        """The best matches so far, best first (covariance_cells 0: the lattice's quantization as the covariance,
        not the score surface's: poses wanted, not their spread)."""
        res = self.matcher.resolution
        out = []
        for a, x, y, total in self._search.results():
            pose = np.array([self._x_ref + x * res, self._y_ref + y * res, float(_wrap(self.thetas[a]))])
            out.append(
                self.matcher._finish(
                    self.points, pose, total, self.angular_step, self.done, self._search.nodes, refine, covariance_cells
                )
            )
        return out


class _BranchAndBound:
    """The resumable depth-first branch and bound over (angle, x, y) blocks shared by match and GlobalSearch."""

    def __init__(
        self,
        matcher: CorrelativeMatcher,
        rows: np.ndarray,
        cols: np.ndarray,
        nx: int,
        ny: int,
        tops: np.ndarray,
        top: int,
        region: np.ndarray | None,
        count: int,
        min_total: int,
        sep2: float,
        angle_sep: float,
        n_angles: int,
    ) -> None:
        self.matcher = matcher
        self.rows, self.cols = rows, cols
        self.nx, self.ny = nx, ny
        self.tops = tops
        self.top = top
        self.region = np.zeros((1, 1, 1), dtype=np.uint8) if region is None else region
        self.use_region = region is not None
        self.count = count
        self.min_total = min_total
        self.sep2, self.angle_sep, self.n_angles = float(sep2), float(angle_sep), int(n_angles)
        self.top_totals = np.zeros(len(tops), dtype=np.int64)
        self.scored = 0  # top nodes scored so far (phase 1)
        self.sorted = False
        # next top, stack size, results, done; the current top block's points on the table throughout it and off it,
        # and its corner (_split_points)
        self.state = np.zeros(8, dtype=np.int64)
        self.inside = np.zeros(rows.shape[1], dtype=np.int64)
        self.outside = np.zeros(rows.shape[1], dtype=np.int64)
        self.stack = np.zeros((4 * matcher.levels + 4, 4), dtype=np.int32)
        self.stack_totals = np.zeros(len(self.stack), dtype=np.int64)
        self.found = np.zeros((count, 3), dtype=np.int32)
        self.found_totals = np.zeros(count, dtype=np.int64)
        self.nodes = 0

    @property
    def done(self) -> bool:
        return bool(self.state[3])

    def run(self, max_nodes: int) -> None:
        budget = max_nodes
        if self.scored < len(self.tops):
            stop = min(len(self.tops), self.scored + budget)
            _score_nodes(
                self.matcher.pyramid,
                self.top,
                self.matcher.pad,
                self.rows,
                self.cols,
                self.tops,
                self.top_totals,
                self.scored,
                stop,
            )
            budget -= stop - self.scored
            self.nodes += stop - self.scored
            self.scored = stop
        if self.scored < len(self.tops):
            return
        if not self.sorted:
            order = np.argsort(-self.top_totals, kind="stable")
            self.tops, self.top_totals = self.tops[order], self.top_totals[order]
            self.sorted = True
        if budget > 0 and not self.done:
            self.nodes += _branch_and_bound(
                self.matcher.pyramid,
                self.matcher.pad,
                self.rows,
                self.cols,
                self.region,
                self.use_region,
                self.nx,
                self.ny,
                self.top,
                self.tops,
                self.top_totals,
                self.state,
                self.stack,
                self.stack_totals,
                self.found,
                self.found_totals,
                self.min_total,
                self.sep2,
                self.angle_sep,
                self.n_angles,
                budget,
                self.inside,
                self.outside,
            )

    def results(self) -> list[tuple[int, int, int, int]]:
        """(angle index, x, y, total) of the best leaves so far, best first."""
        found = self.found[: self.state[2]]
        totals = self.found_totals[: self.state[2]]
        return [(int(a), int(x), int(y), int(t)) for (a, x, y), t in zip(found, totals, strict=True)]


# -- helpers ----------------------------------------------------------------------------------------------


@numba.njit(cache=True, nogil=True)
def _stamped_field(rows, cols, shape, stamp):
    """The largest of `stamp` (a (2 r + 1)^2 square centred on its middle) placed on each of the cells (rows, cols):
    a field within r cells of them; 0 elsewhere."""
    table = np.zeros(shape)
    reach = stamp.shape[0] // 2
    for k in range(len(rows)):
        for i in range(max(rows[k] - reach, 0), min(rows[k] + reach + 1, shape[0])):
            for j in range(max(cols[k] - reach, 0), min(cols[k] + reach + 1, shape[1])):
                value = stamp[i - rows[k] + reach, j - cols[k] + reach]
                if value > table[i, j]:
                    table[i, j] = value
    return table


def _point_table(points, cells, low, shape, resolution: float, sigma: float) -> np.ndarray:
    """exp(-d^2 / (2 sigma^2)), d from each cell's centre to the mean of the points in the nearest cell holding any
    (by the cells' centres; of cells equally near, the lowest column then row), within FIELD_REACH sigmas of the
    points' cells and 0 beyond, as from_points' own field (ScoreMap.from_points with to_points): stamped around the
    occupied cells, not a distance transform of the whole box (a submap's 20 m beams: 800 x 800 cells)."""
    cols, rows = int(shape[0]), int(shape[1])
    flat = cells[:, 1] * cols + cells[:, 0]
    occupied, group = np.unique(flat, return_inverse=True)
    group = group.reshape(-1)
    count = np.bincount(group)
    mean_x = np.bincount(group, weights=points[:, 0]) / count
    mean_y = np.bincount(group, weights=points[:, 1]) / count
    reach = int(math.ceil(FIELD_REACH * sigma / resolution))
    x = low[0] + (np.arange(cols) + 0.5) * resolution
    y = low[1] + (np.arange(rows) + 0.5) * resolution
    d2 = _nearest_cell_means(occupied // cols, occupied % cols, mean_x, mean_y, x, y, reach)
    table = np.zeros((rows, cols), dtype=np.float32)
    near = np.isfinite(d2)
    table[near] = np.exp(-0.5 * d2[near] / (sigma * sigma))
    return table


@numba.njit(cache=True, nogil=True)
def _nearest_cell_means(rows, cols, mean_x, mean_y, x, y, reach):  # pragma: no cover - compiled
    """Squared distance (m^2) from each cell's centre (x[col], y[row]) to the mean of the nearest occupied cell
    within `reach` cells (rows, cols; by the cells' centres; of cells equally near, the lowest column, then row:
    scipy's distance transform's choice), infinite beyond every one."""
    n_rows, n_cols = len(y), len(x)
    table = np.full((n_rows, n_cols), np.inf)
    best = np.full((n_rows, n_cols), -1)
    for k in range(len(rows)):
        for i in range(max(rows[k] - reach, 0), min(rows[k] + reach + 1, n_rows)):
            di = i - rows[k]
            for j in range(max(cols[k] - reach, 0), min(cols[k] + reach + 1, n_cols)):
                dj = j - cols[k]
                b = best[i, j]
                if b >= 0:
                    step = di * di + dj * dj
                    other = (i - rows[b]) ** 2 + (j - cols[b]) ** 2
                    if step > other or (step == other and (cols[k], rows[k]) > (cols[b], rows[b])):
                        continue
                best[i, j] = k
                dx = x[j] - mean_x[k]
                dy = y[i] - mean_y[k]
                table[i, j] = dx * dx + dy * dy
    return table


def _finite_points(points) -> np.ndarray:
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return points[np.isfinite(points).all(axis=1)]


def _window_arguments(who: str, points, prior, linear_window: float, angular_window: float):
    """A windowed search's finite points and prior as arrays; a prior that is not finite or a window that is not a
    number >= 0: ValueError naming the search (`who`) and the argument."""
    points = _finite_points(points)
    prior = np.asarray(prior, dtype=float).reshape(3)
    if not np.isfinite(prior).all():
        raise ValueError(f"{who}: prior must be a finite (x, y, theta), got {prior!r}")
    for name, value in (("linear_window", linear_window), ("angular_window", angular_window)):
        if not math.isfinite(value) or value < 0.0:
            raise ValueError(f"{who}: {name} must be a number >= 0, got {value!r}")
    return points, prior


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _floor_covariance(resolution: float, step: float) -> np.ndarray:
    cell, turn = resolution**2 / 12.0, step**2 / 12.0
    return np.array([[cell, 0.0, 0.0], [0.0, cell, 0.0], [0.0, 0.0, turn]])


def _cells(points: np.ndarray, x_ref: float, y_ref: float, thetas: np.ndarray, origin, resolution: float):
    """(A, N) row and column indices of the cells of the points at poses (x_ref, y_ref, thetas[a]): a pose
    dx, dy whole cells on moves them by exactly dx, dy (the lattice)."""
    points = np.asarray(points, dtype=np.float64)
    rows = np.empty((len(thetas), len(points)), dtype=np.int32)
    cols = np.empty_like(rows)
    _cells_kernel(
        points[:, 0].copy(),
        points[:, 1].copy(),
        float(x_ref),
        float(y_ref),
        np.asarray(thetas, dtype=np.float64),
        float(origin[0]),
        float(origin[1]),
        float(resolution),
        rows,
        cols,
    )
    return rows, cols


@numba.njit(cache=True, nogil=True)
def _cells_kernel(px, py, x_ref, y_ref, thetas, ox, oy, resolution, rows, cols):  # pragma: no cover - compiled
    """_cells in one pass (no (A, N) float temporaries: a windowed match's setup was bound by them)."""
    for a in range(thetas.shape[0]):
        c, s = math.cos(thetas[a]), math.sin(thetas[a])
        for k in range(px.shape[0]):
            wx = x_ref + c * px[k] - s * py[k]
            wy = y_ref + s * px[k] + c * py[k]
            cols[a, k] = int(min(max(math.floor((wx - ox) / resolution), -_FAR), _FAR))
            rows[a, k] = int(min(max(math.floor((wy - oy) / resolution), -_FAR), _FAR))


def _top_blocks(angles: int, blocks: np.ndarray) -> np.ndarray:
    """(angles x blocks x blocks, 3) int32 (angle, x block, y block) rows, angle slowest then y then x: a windowed
    match's top nodes."""
    n = len(blocks)
    tops = np.empty((angles, n, n, 3), dtype=np.int32)
    tops[..., 0] = np.arange(angles, dtype=np.int32)[:, None, None]
    tops[..., 1] = blocks[None, None, :]
    tops[..., 2] = blocks[None, :, None]
    return tops.reshape(-1, 3)


def _max_pyramid(base: np.ndarray, levels: int) -> np.ndarray:
    """(levels, rows, cols): level k at [r, c] the max of base over [r, r + 2^k) x [c, c + 2^k), 0 beyond the
    array (the score pyramid's base is padded on its low sides, so blocks may start before the map)."""
    pyramid = np.zeros((levels, *base.shape), dtype=base.dtype)
    pyramid[0] = base
    for level in range(1, levels):
        half = 1 << (level - 1)
        below = pyramid[level - 1]
        rows = below.copy()
        np.maximum(rows[:-half], below[half:], out=rows[:-half])
        both = rows.copy()
        np.maximum(both[:, :-half], rows[:, half:], out=both[:, :-half])
        pyramid[level] = both
    return pyramid


def _bilinear(table: np.ndarray, u: np.ndarray, v: np.ndarray, scale: float):
    """Values and gradients (d/du, d/dv times scale) of the bilinear interpolation of table at column u,
    row v (cell centres at integers), 0 off the table."""
    value, du, dv = np.empty(len(u)), np.empty(len(u)), np.empty(len(u))
    _bilinear_kernel(table, np.asarray(u, np.float64), np.asarray(v, np.float64), float(scale), value, du, dv)
    return value, du, dv


@numba.njit(cache=True, nogil=True)
def _mean_bilinear(table, px, py, ox, oy, res, pose, value, gx, gy):  # pragma: no cover - compiled
    """The bilinear table at the points moved by pose (values, gradients per m in x and y); their mean."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    u = np.empty(px.shape[0])
    v = np.empty(px.shape[0])
    for k in range(px.shape[0]):
        u[k] = (pose[0] + c * px[k] - s * py[k] - ox) / res - 0.5
        v[k] = (pose[1] + s * px[k] + c * py[k] - oy) / res - 0.5
    _bilinear_kernel(table, u, v, 1.0 / res, value, gx, gy)
    return value.mean()


@numba.njit(cache=True, nogil=True)
def _refine_kernel(table, px, py, ox, oy, res, pose, step, iterations, reach):  # pragma: no cover - compiled
    """CorrelativeMatcher._refine in place on pose; returns the mean score. Each Gauss-Newton step solves the 3x3
    normal equations (Levenberg's 1e-3 of the diagonal added) and backtracks (1, 1/2, 1/4, 1/8 of it) until the
    mean score grows; the pose stays within reach cells and angular steps of where it started."""
    n = px.shape[0]
    start = pose.copy()
    value, gx, gy = np.empty(n), np.empty(n), np.empty(n)
    trial_value, trial_gx, trial_gy = np.empty(n), np.empty(n), np.empty(n)
    best = _mean_bilinear(table, px, py, ox, oy, res, pose, value, gx, gy)
    trial = np.empty(3)
    hessian = np.empty((3, 3))
    gradient = np.empty(3)
    jac = np.empty(3)
    for _ in range(iterations):
        c, s = math.cos(pose[2]), math.sin(pose[2])
        hessian[:, :] = 0.0
        gradient[:] = 0.0
        for k in range(n):
            jac[0] = gx[k]
            jac[1] = gy[k]
            jac[2] = gx[k] * (-s * px[k] - c * py[k]) + gy[k] * (c * px[k] - s * py[k])
            residual = 1.0 - value[k]
            for i in range(3):
                gradient[i] += jac[i] * residual
                for j in range(3):
                    hessian[i, j] += jac[i] * jac[j]
        for i in range(3):
            hessian[i, i] += max(hessian[i, i], 1e-9) * 1e-3
        delta = _solve3(hessian, gradient)
        if not np.isfinite(delta).all():
            break
        score = -np.inf
        for shrink in (1.0, 0.5, 0.25, 0.125):  # backtracking: the bilinear surface is only piecewise smooth
            for i in range(3):
                trial[i] = pose[i] + shrink * delta[i]
            for i in range(2):
                trial[i] = min(max(trial[i], start[i] - reach * res), start[i] + reach * res)
            trial[2] = min(max(trial[2], start[2] - reach * step), start[2] + reach * step)
            score = _mean_bilinear(table, px, py, ox, oy, res, trial, trial_value, trial_gx, trial_gy)
            if score > best:
                break
        if not score > best:
            break
        small = (
            abs(trial[0] - pose[0]) < 1e-4 * res
            and abs(trial[1] - pose[1]) < 1e-4 * res
            and abs(trial[2] - pose[2]) < 1e-4 * step
        )
        pose[:] = trial
        value[:], gx[:], gy[:] = trial_value, trial_gx, trial_gy
        best = score
        if small:
            break
    return best


@numba.njit(cache=True, nogil=True)
def _solve3(a, b):  # pragma: no cover - compiled
    """x with a x = b (3x3, Gaussian elimination with partial pivoting); NaN where a is singular."""
    m = np.empty((3, 4))
    m[:, :3] = a
    m[:, 3] = b
    for col in range(3):
        pivot = col
        for row in range(col + 1, 3):
            if abs(m[row, col]) > abs(m[pivot, col]):
                pivot = row
        if m[pivot, col] == 0.0:
            return np.full(3, np.nan)
        if pivot != col:
            for j in range(4):
                m[col, j], m[pivot, j] = m[pivot, j], m[col, j]
        for row in range(col + 1, 3):
            factor = m[row, col] / m[col, col]
            for j in range(col, 4):
                m[row, j] -= factor * m[col, j]
    x = np.empty(3)
    for row in range(2, -1, -1):
        total = m[row, 3]
        for j in range(row + 1, 3):
            total -= m[row, j] * x[j]
        x[row] = total / m[row, row]
    return x


@numba.njit(cache=True, nogil=True)
def _bilinear_kernel(table, u, v, scale, value, du, dv):  # pragma: no cover - compiled
    """_bilinear, one point at a time (the numpy version built a dozen temporaries per call: 1 ms for 60 points)."""
    rows, cols = table.shape
    for k in range(u.shape[0]):
        c0 = int(math.floor(u[k]))
        r0 = int(math.floor(v[k]))
        fu, fv = u[k] - c0, v[k] - r0
        inside_r0, inside_r1 = 0 <= r0 < rows, 0 <= r0 + 1 < rows
        inside_c0, inside_c1 = 0 <= c0 < cols, 0 <= c0 + 1 < cols
        v00 = table[r0, c0] if inside_r0 and inside_c0 else 0.0
        v01 = table[r0, c0 + 1] if inside_r0 and inside_c1 else 0.0
        v10 = table[r0 + 1, c0] if inside_r1 and inside_c0 else 0.0
        v11 = table[r0 + 1, c0 + 1] if inside_r1 and inside_c1 else 0.0
        value[k] = (1 - fv) * ((1 - fu) * v00 + fu * v01) + fv * ((1 - fu) * v10 + fu * v11)
        du[k] = ((1 - fv) * (v01 - v00) + fv * (v11 - v10)) * scale
        dv[k] = ((1 - fu) * (v10 - v00) + fu * (v11 - v01)) * scale


@numba.njit(cache=True, nogil=True)
def _node_total(pyramid, level, pad, rows, cols, a, x, y):  # pragma: no cover - compiled
    """Sum over the points of pyramid[level] at their cells for angle a, offset (x, y): 0 off the table."""
    height, width = pyramid.shape[1], pyramid.shape[2]
    total = 0
    for i in range(rows.shape[1]):
        r = rows[a, i] + y + pad
        c = cols[a, i] + x + pad
        if r >= 0 and r < height and c >= 0 and c < width:
            total += pyramid[level, r, c]
    return total


@numba.njit(cache=True, nogil=True)
def _split_points(pyramid, pad, rows, cols, a, x0, y0, span, inside, outside, state):  # pragma: no cover - compiled
    """A top block's points for the branch and bound below it (angle a, corner (x0, y0), span cells a side): those
    whose cells stay on the table at every node of the block, as their flat index at the corner (inside), and the
    others' numbers (outside); their counts and the corner in state[4:8]."""
    height, width = pyramid.shape[1], pyramid.shape[2]
    n_in = 0
    n_out = 0
    for i in range(rows.shape[1]):
        r = np.int64(rows[a, i]) + pad + y0
        c = np.int64(cols[a, i]) + pad + x0
        if r >= 0 and c >= 0 and r + span <= height and c + span <= width:
            inside[n_in] = r * width + c
            n_in += 1
        else:
            outside[n_out] = i
            n_out += 1
    state[4] = n_in
    state[5] = n_out
    state[6] = x0
    state[7] = y0


@numba.njit(cache=True, nogil=True)
def _block_total(flat, pyramid, level, pad, rows, cols, a, x, y, inside, outside, state):  # pragma: no cover
    """_node_total of a node within the current top block (_split_points): the points on the table throughout it
    summed from their flat index plus the node's offset (no bounds to check), the others as _node_total does. The
    same integer."""
    height, width = pyramid.shape[1], pyramid.shape[2]
    offset = level * height * width + (y - state[7]) * width + (x - state[6])
    total = 0
    for k in range(state[4]):
        total += flat[inside[k] + offset]
    for k in range(state[5]):
        i = outside[k]
        r = rows[a, i] + y + pad
        c = cols[a, i] + x + pad
        if r >= 0 and r < height and c >= 0 and c < width:
            total += pyramid[level, r, c]
    return total


@numba.njit(cache=True, nogil=True)
def _score_nodes(pyramid, level, pad, rows, cols, nodes, out, start, stop):  # pragma: no cover - compiled
    for k in range(start, stop):
        out[k] = _node_total(pyramid, level, pad, rows, cols, nodes[k, 0], nodes[k, 1], nodes[k, 2])


@numba.njit(cache=True, nogil=True)
def _lattice_totals(pyramid, pad, rows, cols, out):  # pragma: no cover - compiled
    """out[a, y, x]: level-0 totals of every pose of a small lattice (_node_total at each, the same integers): per
    heading, the points whose cells stay on the table across the whole window are summed at each pose from their
    flat index plus the pose's offset (no bounds to check, no index to compute), the others pose by pose."""
    height, width = pyramid.shape[1], pyramid.shape[2]
    size_y, size_x = out.shape[1], out.shape[2]
    table = pyramid[0].ravel()
    inside = np.empty(rows.shape[1], dtype=np.int64)
    for a in range(out.shape[0]):
        count = 0
        for i in range(rows.shape[1]):
            r, c = np.int64(rows[a, i]) + pad, np.int64(cols[a, i]) + pad
            if r >= 0 and c >= 0 and r + size_y <= height and c + size_x <= width:
                inside[count] = r * width + c
                count += 1
        for y in range(size_y):
            for x in range(size_x):
                offset = y * width + x
                total = 0
                for k in range(count):
                    total += table[inside[k] + offset]
                out[a, y, x] = total
        for i in range(rows.shape[1]):
            r, c = np.int64(rows[a, i]) + pad, np.int64(cols[a, i]) + pad
            if r >= 0 and c >= 0 and r + size_y <= height and c + size_x <= width:
                continue
            for y in range(max(0, -r), min(size_y, height - r)):
                for x in range(max(0, -c), min(size_x, width - c)):
                    out[a, y, x] += table[(r + y) * width + c + x]


@numba.njit(cache=True, nogil=True)
def _near(a, x, y, fa, fx, fy, sep2, angle_sep, n_angles):  # pragma: no cover - compiled
    dx = x - fx
    dy = y - fy
    da = abs(a - fa)
    if n_angles > 0:
        da = min(da, n_angles - da)
    return dx * dx + dy * dy < sep2 and da < angle_sep


@numba.njit(cache=True, nogil=True)
def _keep_leaf(found, found_totals, state, total, a, x, y, sep2, angle_sep, n_angles):  # pragma: no cover
    """Add a leaf to the best well-separated leaves (sorted best first): it replaces the worse ones near it,
    and is dropped if a better one is near."""
    n = state[2]
    for j in range(n):
        near = _near(a, x, y, found[j, 0], found[j, 1], found[j, 2], sep2, angle_sep, n_angles)
        if near and found_totals[j] >= total:
            return
    k = 0
    for j in range(n):
        if not _near(a, x, y, found[j, 0], found[j, 1], found[j, 2], sep2, angle_sep, n_angles):
            found[k] = found[j]
            found_totals[k] = found_totals[j]
            k += 1
    n = k
    if n == found.shape[0]:
        n -= 1  # the worst goes (total beat the threshold, so it beats the worst)
    pos = n
    while pos > 0 and found_totals[pos - 1] < total:
        found[pos] = found[pos - 1]
        found_totals[pos] = found_totals[pos - 1]
        pos -= 1
    found[pos, 0] = a
    found[pos, 1] = x
    found[pos, 2] = y
    found_totals[pos] = total
    state[2] = n + 1


@numba.njit(cache=True, nogil=True)
def _threshold(found_totals, state, min_total):  # pragma: no cover - compiled
    """A node is worth opening when its bound is above this."""
    if state[2] == found_totals.shape[0]:
        return found_totals[state[2] - 1]
    return min_total - 1


@numba.njit(cache=True, nogil=True)
def _branch_and_bound(
    pyramid,
    pad,
    rows,
    cols,
    region,
    use_region,
    nx,
    ny,
    top,
    tops,
    top_totals,
    state,
    stack,
    stack_totals,
    found,
    found_totals,
    min_total,
    sep2,
    angle_sep,
    n_angles,
    max_nodes,
    inside,
    outside,
):  # pragma: no cover - compiled
    """Depth-first branch and bound from the top nodes (sorted best first) until done or max_nodes nodes
    scored; all progress lives in state, stack, found, inside and outside, so a next call continues. Returns nodes
    scored. A top block's points are split once into those on the table at every node below it and the others
    (_split_points): its nodes sum the first without bounds checks (_block_total; the same totals)."""
    nodes = 0
    flat = pyramid.ravel()
    span = 1 << top
    child = np.zeros((4, 3), dtype=np.int32)
    child_totals = np.zeros(4, dtype=np.int64)
    while nodes < max_nodes:
        sp = state[1]
        if sp == 0:
            ti = state[0]
            if ti >= tops.shape[0] or top_totals[ti] <= _threshold(found_totals, state, min_total):
                state[0] = tops.shape[0]
                state[3] = 1
                break
            stack[0, 0] = top
            stack[0, 1] = tops[ti, 0]
            stack[0, 2] = tops[ti, 1]
            stack[0, 3] = tops[ti, 2]
            stack_totals[0] = top_totals[ti]
            state[0] = ti + 1
            state[1] = 1
            _split_points(pyramid, pad, rows, cols, tops[ti, 0], tops[ti, 1], tops[ti, 2], span, inside, outside, state)
            continue
        sp -= 1
        state[1] = sp
        level, a, x, y = stack[sp, 0], stack[sp, 1], stack[sp, 2], stack[sp, 3]
        total = stack_totals[sp]
        threshold = _threshold(found_totals, state, min_total)
        if total <= threshold:
            continue
        if level == 0:
            _keep_leaf(found, found_totals, state, total, a, x, y, sep2, angle_sep, n_angles)
            continue
        half = 1 << (level - 1)
        n = 0
        for k in range(4):
            cx = x + half * (k & 1)
            cy = y + half * (k >> 1)
            if cx >= nx or cy >= ny:
                continue
            if use_region and region[level - 1, cy, cx] == 0:
                continue
            t = _block_total(flat, pyramid, level - 1, pad, rows, cols, a, cx, cy, inside, outside, state)
            nodes += 1
            if t > threshold:
                pos = n  # insertion sort, ascending: the best is pushed last and popped first
                while pos > 0 and child_totals[pos - 1] > t:
                    child[pos] = child[pos - 1]
                    child_totals[pos] = child_totals[pos - 1]
                    pos -= 1
                child[pos, 0] = cx
                child[pos, 1] = cy
                child[pos, 2] = a
                child_totals[pos] = t
                n += 1
        for k in range(n):
            stack[sp, 0] = level - 1
            stack[sp, 1] = child[k, 2]
            stack[sp, 2] = child[k, 0]
            stack[sp, 3] = child[k, 1]
            stack_totals[sp] = child_totals[k]
            sp += 1
        state[1] = sp
    return nodes
