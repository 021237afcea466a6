"""Clusters of particles: a DBSCAN-like, density-based grouping on a grid hash.

Particles are binned in cells of side `radius` (and, given headings, of `heading_bin` rad in heading,
which wraps around); a cell holding at least `min_size` particles is dense, and dense cells touching
(8-neighbourhood in the plane, 26 with headings) form one cluster (scipy.ndimage.label, the heading's
first and last bins joined). Particles in sparse cells are noise, as in DBSCAN. It costs one
histogram and one labelling, whatever the particle count (a neighbour search over 5,000 tight
particles would be quadratic). With headings, two places that differ by a turn on the spot (a
symmetric room's quarter turns) are two clusters, not one with a meaningless mean heading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import label
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
    if headings is not None:
        bins = max(1, int(round(2.0 * math.pi / heading_bin)))
        turn = np.floor(np.mod(headings, 2.0 * math.pi) / (2.0 * math.pi) * bins).astype(np.int64) % bins
        cells = np.column_stack([cells, turn])
    low = cells.min(axis=0)
    low[2:] = 0
    cells -= low
    shape = tuple(cells.max(axis=0) + 1)
    if headings is not None:
        shape = shape[:2] + (bins,)
    flat = np.ravel_multi_index(tuple(cells.T), shape)
    counts = np.bincount(flat, minlength=int(np.prod(shape))).reshape(shape)
    dense = counts >= min_size
    cell_labels, count = label(dense, structure=np.ones((3,) * len(shape), dtype=bool))
    if headings is not None and count and shape[2] > 2:
        cell_labels, count = _join_wrapped(cell_labels, count)
    labels = cell_labels.ravel()[flat] - 1
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


def _join_wrapped(cell_labels: np.ndarray, count: int) -> tuple[np.ndarray, int]:
    """Labels joined across the heading's wrap (the last bin touches the first, 8-neighbourhood in the plane)."""
    first, last = cell_labels[:, :, 0], cell_labels[:, :, -1]
    pairs = []
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            shifted = np.roll(np.roll(last, dr, axis=0), dc, axis=1)
            both = (first > 0) & (shifted > 0)
            pairs.append(np.column_stack([first[both], shifted[both]]))
    pairs = np.concatenate(pairs) if pairs else np.zeros((0, 2), dtype=np.int64)
    if not len(pairs):
        return cell_labels, count
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0] - 1, pairs[:, 1] - 1)), shape=(count, count))
    joined, component = connected_components(graph, directed=False)
    relabel = np.concatenate([[0], component + 1])
    return relabel[cell_labels], joined
