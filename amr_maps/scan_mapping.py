"""Occupancy mapping with known poses: log odds per cell (Thrun, Burgard, Fox, Probabilistic Robotics, 9.2).

Each scan adds, once per cell it touches, l_occ to the cell of each beam's end point and l_free to every
cell the beam crosses before it (an exact grid traversal, Amanatides and Woo, compiled); a reading without
a return (+inf, or beyond max_range_used) clears its beam up to max_range_used and marks nothing occupied;
NaN and -inf readings (REP 117: closer than range_min) are skipped. A cell both ended on and crossed in one
scan counts as occupied. The sums are kept unclamped (and a count of the scans that touched each cell), and
clamped only when read: inserting a scan with sign=-1 then takes it out exactly, so a SLAM can remove its
scans and insert them again at their optimized poses.

The grid grows as scans arrive: it is reallocated to hold every cell a scan touches, with a margin, on the
lattice x = origin_x + k * resolution fixed by the first origin (cells keep their alignment).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba
import numpy as np

from amr_maps.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from amr_util.geometry import compose
from amr_util.scan import ScanData

PROBABILITY_BAND = 1e-9
"""Log odds this close to a level's are compared through the probability itself (LogOddsGrid.probability_at_least):
beyond it, a rounding of the exponential cannot cross the level."""


class LogOddsGrid:
    """A growing log-odds occupancy grid; `origin` (x, y) is cell (0, 0)'s lower-left corner, row 0 the lowest y
    (amr_maps.occupancy_grid's layout)."""

    def __init__(
        self,
        resolution: float,
        origin: tuple[float, float] | None = None,
        l_occ: float = 0.85,
        l_free: float = -0.4,
        clamp: tuple[float, float] = (-2.0, 3.5),
        margin: float = 2.0,
    ) -> None:
        if not math.isfinite(resolution) or resolution <= 0.0:
            raise ValueError(f"log-odds grid: resolution must be a positive number of m/cell, got {resolution!r}")
        if not (math.isfinite(l_occ) and l_occ > 0.0 and math.isfinite(l_free) and l_free < 0.0):
            raise ValueError(f"log-odds grid: l_occ must be > 0 and l_free < 0, got {l_occ!r}, {l_free!r}")
        if len(clamp) != 2 or not (clamp[0] < 0.0 < clamp[1]):
            raise ValueError(f"log-odds grid: clamp must be (low < 0, high > 0), got {clamp!r}")
        if not math.isfinite(margin) or margin < 0.0:
            raise ValueError(f"log-odds grid: margin must be a number of m >= 0, got {margin!r}")
        if origin is not None and not all(math.isfinite(float(v)) for v in origin[:2]):
            raise ValueError(f"log-odds grid: origin must be finite (x, y), got {origin!r}")
        self.resolution = float(resolution)
        self.l_occ, self.l_free = float(l_occ), float(l_free)
        self.clamp = (float(clamp[0]), float(clamp[1]))
        self.margin = float(margin)
        self._anchor = (0.0, 0.0) if origin is None else (float(origin[0]), float(origin[1]))
        self._low = np.zeros(2, dtype=np.int64)  # (col, row) of cell (0, 0) on the anchor's lattice
        self._sum = np.zeros((0, 0))
        self._count = np.zeros((0, 0), dtype=np.int32)
        self._mark = np.zeros((0, 0), dtype=np.int64)
        self._scans = 0

    @property
    def origin(self) -> tuple[float, float]:
        """(x, y) of cell (0, 0)'s lower-left corner."""
        return (self._anchor[0] + self._low[0] * self.resolution, self._anchor[1] + self._low[1] * self.resolution)

    @property
    def shape(self) -> tuple[int, int]:
        return int(self._sum.shape[0]), int(self._sum.shape[1])

    def log_odds(self) -> np.ndarray:
        """(rows, cols) clamped log odds, 0 where never observed."""
        return np.clip(self._sum, *self.clamp)

    def observed(self) -> np.ndarray:
        """(rows, cols) True where a scan touched the cell."""
        return self._count > 0

    def probability(self, unknown: float = 0.5) -> np.ndarray:
        """(rows, cols) occupancy probability 1 - 1 / (1 + exp(l)); `unknown` where never observed."""
        probability = 1.0 - 1.0 / (1.0 + np.exp(self.log_odds()))
        return np.where(self.observed(), probability, unknown)

    def probability_at_least(self, level: float, unknown: float = 0.5) -> np.ndarray:
        """probability(unknown) >= level, cell for cell, without every cell's exponential: the log odds compared
        with level's, the probability computed only for the cells within PROBABILITY_BAND of it (the formula is
        monotone in the log odds, so the others compare the same)."""
        return self._compare(level, unknown, True)

    def probability_at_most(self, level: float, unknown: float = 0.5) -> np.ndarray:
        """probability(unknown) <= level, cell for cell (see probability_at_least)."""
        return self._compare(level, unknown, False)

    def _compare(self, level: float, unknown: float, at_least: bool) -> np.ndarray:
        level = float(level)
        threshold = math.log(level / (1.0 - level)) if 0.0 < level < 1.0 else math.nan
        if not self.clamp[0] + PROBABILITY_BAND < threshold < self.clamp[1] - PROBABILITY_BAND:
            probability = self.probability(unknown)  # a level the clamp decides: the formula itself
            return probability >= level if at_least else probability <= level
        unseen = bool(unknown >= level) if at_least else bool(unknown <= level)
        mask = np.empty(self._sum.shape, dtype=bool)
        near = np.empty(self._sum.size, dtype=np.int64)
        found = _compare_log_odds(self._sum, self._count, threshold, PROBABILITY_BAND, at_least, unseen, mask, near)
        if found:
            rows, cols = np.divmod(near[:found], self._sum.shape[1])
            probability = 1.0 - 1.0 / (1.0 + np.exp(np.clip(self._sum[rows, cols], *self.clamp)))
            mask[rows, cols] = probability >= level if at_least else probability <= level
        return mask

    def to_occupancy_grid(self, occupied: float = 0.65, free: float = 0.25, frame_id: str = "map") -> OccupancyGrid:
        """100 at or above `occupied`, 0 at or below `free`, round(100 p) between, -1 where never observed. An
        empty grid (no scan yet) is one unknown cell at the origin."""
        if self._sum.size == 0:
            return OccupancyGrid(
                np.full((1, 1), UNKNOWN, dtype=np.int8), self.resolution, (*self.origin, 0.0), frame_id
            )
        probability = self.probability()
        data = np.rint(100.0 * probability).astype(np.int8)
        data[probability >= occupied] = OCCUPIED
        data[probability <= free] = FREE
        data[~self.observed()] = UNKNOWN
        return OccupancyGrid(data, self.resolution, (*self.origin, 0.0), frame_id)

    def insert(self, pose, ranges, angles, max_range_used: float = math.inf, sign: int = 1) -> None:
        """Add a scan taken by a sensor at pose (x, y, theta) in the map frame: ranges along angles (sensor
        frame). sign=-1 takes out a scan inserted before with the same arguments (the same cells, exactly)."""
        if sign not in (1, -1):
            raise ValueError(f"insert: sign must be 1 or -1, got {sign!r}")
        beams = self._beams(pose, ranges, angles, max_range_used)
        if beams is not None:
            self._cover(np.vstack([beams[1], beams[0][None, :2]]))
            self._apply(*beams, sign)

    def insert_many(self, poses, ranges, angles, max_ranges, sign: int = 1) -> None:
        """insert for each scan in turn (poses (N, 3), sequences of N ranges, angles and max_range_used): the same
        cells, values and origin, but the arrays allocated once at the extent the scans grow the grid to (each
        scan traced in the extent it would have had, a view of them), not reallocated and copied at each growth."""
        if sign not in (1, -1):
            raise ValueError(f"insert: sign must be 1 or -1, got {sign!r}")
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        if not len(poses) == len(ranges) == len(angles) == len(max_ranges):
            raise ValueError(
                f"insert_many: {len(poses)} poses, {len(ranges)} ranges, {len(angles)} angles, {len(max_ranges)} "
                "max_ranges"
            )
        scans = [
            b
            for b in (self._beams(*args) for args in zip(poses, ranges, angles, max_ranges, strict=True))
            if b is not None
        ]
        if not scans:
            return
        height, width = self._sum.shape
        low, size = self._low.copy(), np.array([width, height])
        extents = []
        for pose, ends, _ in scans:
            grown = self._grown(np.vstack([ends, pose[None, :2]]), low, size)
            if grown is not None:
                low, size = grown
            extents.append((low, size))
        if self._sum.size == 0 or np.any(low != self._low) or np.any(size != (width, height)):
            self._reallocate(low, size)
        allocated = self._low
        for (pose, ends, hit), (low, size) in zip(scans, extents, strict=True):
            c0, r0 = low - allocated
            self._low = low  # the origin this scan would have had (the last scan's is the arrays')
            self._apply(pose, ends, hit, sign, (int(r0), int(c0), int(size[1]), int(size[0])))

    def _beams(self, pose, ranges, angles, max_range_used: float):
        """(pose, the beams' end points (map frame), which end on a return) of a scan to insert; None: no beam."""
        pose = np.asarray(pose, dtype=float).reshape(3)
        if not np.all(np.isfinite(pose)):
            raise ValueError(f"insert: pose must be a finite (x, y, theta), got {pose!r}")
        if math.isnan(max_range_used) or max_range_used <= 0.0:
            raise ValueError(f"insert: max_range_used must be a positive number of m (or inf), got {max_range_used!r}")
        ranges = np.asarray(ranges, dtype=float).ravel()
        angles = np.asarray(angles, dtype=float).ravel()
        if ranges.shape != angles.shape:
            raise ValueError(f"insert: {ranges.size} ranges for {angles.size} angles")
        usable = np.isfinite(angles) & ~np.isnan(ranges) & (ranges > 0.0)
        hit = usable & np.isfinite(ranges) & (ranges <= max_range_used)
        clear = usable & ~hit & math.isfinite(max_range_used)  # +inf or too far: free up to max_range_used
        length = np.where(hit, ranges, max_range_used if math.isfinite(max_range_used) else 0.0)
        keep = hit | clear
        if not keep.any():
            return None
        heading = pose[2] + angles[keep]
        ends = np.column_stack([pose[0] + length[keep] * np.cos(heading), pose[1] + length[keep] * np.sin(heading)])
        return pose, ends, hit[keep]

    def _apply(self, pose, ends, hit, sign: int, view=None) -> None:
        """One scan's cells updated (the arrays cover them); view: (row, col, rows, cols) of the arrays the scan is
        traced in (insert_many's extent of it), the whole arrays by default."""
        ox, oy = self.origin
        start = np.array([(pose[0] - ox) / self.resolution, (pose[1] - oy) / self.resolution])
        # x's then y's, each contiguous: column views type apart when a scan has one end (a second compile)
        ends_cells = np.ascontiguousarray(((ends - (ox, oy)) / self.resolution).T)
        self._scans += 1
        _update(
            self._sum,
            self._count,
            self._mark,
            *(view or (0, 0, *self._sum.shape)),
            2 * self._scans,
            start[0],
            start[1],
            ends_cells[0],
            ends_cells[1],
            hit,
            sign * self.l_occ,
            sign * self.l_free,
            sign,
        )

    def insert_scan(
        self, pose, scan: ScanData, mount=(0.0, 0.0, 0.0), max_range_used: float | None = None, sign: int = 1
    ) -> None:
        """insert for a ScanData taken with the robot at pose and the sensor at mount in the robot frame:
        readings below range_min are skipped, above range_max are no returns; max_range_used defaults to
        range_max (no clearing when it is infinite)."""
        ranges = np.asarray(scan.ranges, dtype=float)
        angles = scan.angle_min + scan.angle_increment * np.arange(ranges.size)
        ranges = np.where(ranges < scan.range_min, np.nan, ranges)
        ranges = np.where(ranges > scan.range_max, np.inf, ranges)
        limit = scan.range_max if max_range_used is None else max_range_used
        self.insert(
            np.asarray(compose(tuple(np.asarray(pose, dtype=float)), tuple(mount))),
            ranges,
            angles,
            min(limit, scan.range_max),
            sign,
        )

    def _cover(self, points: np.ndarray) -> None:
        """Grow the arrays (with the margin) so that every point's cell is inside, keeping the lattice."""
        height, width = self._sum.shape
        grown = self._grown(points, self._low, np.array([width, height]))
        if grown is not None:
            self._reallocate(*grown)

    def _grown(self, points: np.ndarray, low: np.ndarray, size: np.ndarray):
        """(low, size) of the arrays (col, row) once grown to cover the points (with the margin) from (low, size);
        None when they already do."""
        res = self.resolution
        cols = np.floor((points[:, 0] - self._anchor[0]) / res).astype(np.int64)
        rows = np.floor((points[:, 1] - self._anchor[1]) / res).astype(np.int64)
        new_low = np.array([cols.min(), rows.min()])
        high = np.array([cols.max(), rows.max()]) + 1
        empty = size[0] * size[1] == 0
        if not empty and np.all(new_low >= low) and np.all(high <= low + size):
            return None
        margin = int(math.ceil(self.margin / res))
        if not empty:
            new_low = np.minimum(new_low, low)
            high = np.maximum(high, low + size)
        new_low -= margin
        high += margin
        return new_low, high - new_low

    def _reallocate(self, low: np.ndarray, size: np.ndarray) -> None:
        """New arrays of `size` (cols, rows) at `low` on the lattice, the cells so far copied in."""
        total = np.zeros((size[1], size[0]))
        count = np.zeros((size[1], size[0]), dtype=np.int32)
        mark = np.zeros((size[1], size[0]), dtype=np.int64)
        if self._sum.size:
            height, width = self._sum.shape
            c0, r0 = self._low - low
            total[r0 : r0 + height, c0 : c0 + width] = self._sum
            count[r0 : r0 + height, c0 : c0 + width] = self._count
            mark[r0 : r0 + height, c0 : c0 + width] = self._mark
        self._sum, self._count, self._mark, self._low = total, count, mark, low


def map_from_scans(
    poses: np.ndarray,
    scans: Sequence[ScanData],
    resolution: float = 0.05,
    max_range: float | None = None,
    mount=(0.0, 0.0, 0.0),
    occupied: float = 0.65,
    free: float = 0.25,
    frame_id: str = "map",
    origin: tuple[float, float] | None = None,
) -> OccupancyGrid:
    """The occupancy grid of scans taken at poses (N, 3) of the robot (sensor at mount in the robot frame):
    no returns clear up to max_range (default: each scan's range_max; nothing when that is infinite). origin:
    a point of the cell lattice (default (0, 0)), to align the map on another grid's cells."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    if len(poses) != len(scans):
        raise ValueError(f"map_from_scans: {len(poses)} poses for {len(scans)} scans")
    grid = LogOddsGrid(resolution, origin)
    for pose, scan in zip(poses, scans, strict=True):
        grid.insert_scan(pose, scan, mount, max_range)
    return grid.to_occupancy_grid(occupied, free, frame_id)


@numba.njit(cache=True)
def _compare_log_odds(total, count, threshold, band, at_least, unseen, mask, near):  # pragma: no cover - compiled
    """LogOddsGrid._compare's pass: mask from the log odds against threshold (unseen where never observed); the
    cells within band of it listed in near (flat indices; their count returned) for the formula itself."""
    found = 0
    rows, cols = total.shape
    for r in range(rows):
        for c in range(cols):
            value = total[r, c]
            if count[r, c] <= 0:
                mask[r, c] = unseen
            elif abs(value - threshold) <= band:
                mask[r, c] = False
                near[found] = r * cols + c
                found += 1
            else:
                mask[r, c] = value >= threshold if at_least else value <= threshold
    return found


@numba.njit(cache=True)
def _update(total, count, mark, r0, c0, rows, cols, tag, x0, y0, xs, ys, hit, l_occ, l_free, sign):  # pragma: no cover
    """One scan, in cell units from the grid's origin: end cells of hits first (tag: occupied this scan), then
    every cell each beam crosses (tag + 1: free this scan), each cell once. The grid: rows x cols cells of the
    arrays from (r0, c0) on (LogOddsGrid.insert_many's view; the whole arrays for insert)."""
    for k in range(xs.shape[0]):
        if hit[k]:
            c = int(math.floor(xs[k]))
            r = int(math.floor(ys[k]))
            if mark[r0 + r, c0 + c] != tag:
                mark[r0 + r, c0 + c] = tag
                total[r0 + r, c0 + c] += l_occ
                count[r0 + r, c0 + c] += sign
    for k in range(xs.shape[0]):
        ix = int(math.floor(x0))
        iy = int(math.floor(y0))
        ex = int(math.floor(xs[k]))
        ey = int(math.floor(ys[k]))
        dx = xs[k] - x0
        dy = ys[k] - y0
        step_x = 1 if dx > 0.0 else -1
        step_y = 1 if dy > 0.0 else -1
        delta_x = abs(1.0 / dx) if dx != 0.0 else math.inf
        delta_y = abs(1.0 / dy) if dy != 0.0 else math.inf
        next_x = ((ix + 1.0 - x0) if dx > 0.0 else (x0 - ix)) * delta_x if dx != 0.0 else math.inf
        next_y = ((iy + 1.0 - y0) if dy > 0.0 else (y0 - iy)) * delta_y if dy != 0.0 else math.inf
        steps = abs(ex - ix) + abs(ey - iy)
        for _ in range(steps + 1):
            if ix == ex and iy == ey and hit[k]:
                break  # the end cell of a return is occupied
            if (
                0 <= iy < rows
                and 0 <= ix < cols
                and mark[r0 + iy, c0 + ix] != tag
                and mark[r0 + iy, c0 + ix] != tag + 1
            ):
                mark[r0 + iy, c0 + ix] = tag + 1
                total[r0 + iy, c0 + ix] += l_free
                count[r0 + iy, c0 + ix] += sign
            if ix == ex and iy == ey:
                break
            if next_x < next_y:
                ix += step_x
                next_x += delta_x
            else:
                iy += step_y
                next_y += delta_y
