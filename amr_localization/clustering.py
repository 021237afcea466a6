"""Clusters of particles: a DBSCAN-like, density-based grouping on a grid hash.

Particles are binned in square cells of side `radius`; a cell holding at least
`min_size` particles is dense, and dense cells touching (8-neighbourhood) form
one cluster (scipy.ndimage.label). Particles in sparse cells are noise, as in
DBSCAN. It costs one 2D histogram and one labelling, whatever the particle
count (a neighbour search over 5,000 tight particles would be quadratic).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import label

EIGHT_NEIGHBOURS = np.ones((3, 3), dtype=bool)


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


def cluster_particles(xy: np.ndarray, weights: np.ndarray, radius: float, min_size: int) -> Clusters:
    """Clusters of the (N, 2) positions, ranked by weight."""
    cells = np.floor(xy / radius).astype(np.int64)
    low = cells.min(axis=0)
    cells -= low
    shape = tuple(cells.max(axis=0) + 1)
    flat = np.ravel_multi_index((cells[:, 0], cells[:, 1]), shape)
    counts = np.bincount(flat, minlength=shape[0] * shape[1]).reshape(shape)
    cell_labels, count = label(counts >= min_size, structure=EIGHT_NEIGHBOURS)
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
