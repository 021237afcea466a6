"""Clusters of particles: a DBSCAN-like, density-based grouping on a grid hash.

Particles are binned in cells of side `radius` (and, given headings, of `heading_bin` rad in heading,
which wraps around); a cell holding at least `min_size` particles is dense, and dense cells touching
(8-neighbourhood in the plane, 26 with headings) form one cluster (the heading's first and last bins
joined). Particles in sparse cells are noise, as in DBSCAN. It costs one sort of the particles' cells and
a look-up of each dense cell's neighbours, whatever the particle count (a neighbour search over 5,000 tight
particles would be quadratic) and however far the cloud spreads. With headings, two places that differ by a
turn on the spot (a symmetric room's quarter turns) are two clusters, not one with a meaningless mean heading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True)
class Clusters:
    labels: np.ndarray
    """(N,) cluster of each particle, -1 for noise."""
    weights: np.ndarray
    """(C,) total weight of each cluster, heaviest first (labels are ranked the same way)."""
    sizes: np.ndarray
    """(C,) particles in each cluster."""

    @property
    def count(self) -> int:
        return len(self.weights)


def cluster_particles(
    xy: np.ndarray,
    weights: np.ndarray,
    radius: float,
    min_size: int,
    headings: np.ndarray | None = None,
    heading_bin: float = math.pi / 12,
) -> Clusters:
    """Clusters of the (N, 2) positions (and headings, if given), ranked by weight."""
    cells = np.floor(xy / radius).astype(np.int64)
    bins = 0
    if headings is not None:
        bins = max(1, int(round(2.0 * math.pi / heading_bin)))
        turn = np.floor(np.mod(headings, 2.0 * math.pi) / (2.0 * math.pi) * bins).astype(np.int64) % bins
        cells = np.column_stack([cells, turn])
    low = cells.min(axis=0)
    low[2:] = 0
    cells -= low
    # one more cell on each side of the plane, so that a neighbour's index never wraps into another row
    cells[:, :2] += 1
    shape = tuple(cells.max(axis=0) + 2)
    if headings is not None:
        shape = shape[:2] + (bins,)
    flat = np.ravel_multi_index(tuple(cells.T), shape)
    occupied, inverse, counts = np.unique(flat, return_inverse=True, return_counts=True)
    dense = occupied[counts >= min_size]  # sorted: raster order, as scipy.ndimage.label numbers its labels
    component = _touching(dense, shape, wrap=headings is not None and bins > 2)
    count = int(component.max()) + 1 if len(dense) else 0
    cell_label = np.full(len(occupied), -1, dtype=np.int64)
    cell_label[counts >= min_size] = component
    labels = cell_label[inverse.reshape(-1)]
    if count == 0:
        return Clusters(labels, np.zeros(0), np.zeros(0, dtype=np.int64))
    member = labels >= 0
    cluster_weights = np.bincount(labels[member], weights=weights[member], minlength=count)
    sizes = np.bincount(labels[member], minlength=count)
    order = np.argsort(-cluster_weights, kind="stable")
    rank = np.empty(count, dtype=np.int64)
    rank[order] = np.arange(count)
    labels = np.where(member, rank[np.maximum(labels, 0)], -1)
    return Clusters(labels, cluster_weights[order], sizes[order])


def _touching(dense: np.ndarray, shape: tuple[int, ...], wrap: bool) -> np.ndarray:
    """(D,) the component of each dense cell (sorted flat indices into `shape`), cells touching in the 8 (26 with
    headings) neighbourhood joined, the heading's last bin touching its first where `wrap`; components numbered in
    the order of their first cell. Only the dense cells are visited: the cost is theirs, not the bounding box's (a
    cloud spread over a 100 m map is tens of millions of cells)."""
    if not len(dense):
        return np.zeros(0, dtype=np.int64)
    dims = np.array(tuple(shape) + (1,) * (3 - len(shape)), dtype=np.int64)
    component = np.empty(len(dense), dtype=np.int64)
    _components(np.asarray(dense, dtype=np.int64), dims, len(shape) > 2, wrap, component)
    return component


@numba.njit(cache=True, nogil=True)
def _root(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(cache=True, nogil=True)
def _components(dense, dims, headings, wrap, out):
    """Union-find over the dense cells: each cell joined to its neighbours found among them (binary search)."""
    cols, bins = dims[1], dims[2]
    parent = np.arange(dense.shape[0])
    reach = 1 if headings else 0
    for i in range(dense.shape[0]):
        key = dense[i]
        h = key % bins
        c = (key // bins) % cols
        r = key // (bins * cols)
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                for dh in range(-reach, reach + 1):
                    if dr == 0 and dc == 0 and dh == 0:
                        continue
                    nh = h + dh
                    if nh < 0 or nh >= bins:
                        if not wrap:
                            continue
                        nh %= bins
                    neighbour = ((r + dr) * cols + (c + dc)) * bins + nh
                    j = np.searchsorted(dense, neighbour)
                    if j < dense.shape[0] and dense[j] == neighbour:
                        a, b = _root(parent, i), _root(parent, j)
                        if a != b:
                            parent[max(a, b)] = min(a, b)
    number = np.full(dense.shape[0], -1, dtype=np.int64)
    count = 0
    for i in range(dense.shape[0]):  # in the order of each component's first cell
        root = _root(parent, i)
        if number[root] < 0:
            number[root] = count
            count += 1
        out[i] = number[root]
