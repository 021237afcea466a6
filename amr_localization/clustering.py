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

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


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
    index = np.array(np.unravel_index(dense, shape)).T
    rows, cols = [], []
    for offset in itertools.product((-1, 0, 1), repeat=len(shape)):
        if not any(offset):
            continue
        neighbour = index + offset
        if wrap:
            neighbour[:, 2] %= shape[2]
        elif len(shape) > 2:
            inside = (neighbour[:, 2] >= 0) & (neighbour[:, 2] < shape[2])
            neighbour = np.where(inside[:, None], neighbour, index)
        keys = np.ravel_multi_index(tuple(neighbour.T), shape)
        at = np.minimum(np.searchsorted(dense, keys), len(dense) - 1)
        found = dense[at] == keys
        rows.append(np.flatnonzero(found))
        cols.append(at[found])
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(dense), len(dense)))
    _, component = connected_components(graph, directed=False)
    first = np.full(component.max() + 1, len(dense))
    np.minimum.at(first, component, np.arange(len(dense)))
    number = np.empty(len(first), dtype=np.int64)
    number[np.argsort(first, kind="stable")] = np.arange(len(first))
    return number[component]
