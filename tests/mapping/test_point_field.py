"""amr_mapping.point_field: the submaps' lines found on a grid are a k-d tree's."""

import numpy as np
from scipy.spatial import cKDTree

from amr_mapping.point_field import neighbourhood_lines


def _cloud(seed: int = 0) -> np.ndarray:
    """Walls (a corridor, a crossing wall) and clutter: ties between equally near cells, lines and corners."""
    rng = np.random.default_rng(seed)
    along = rng.uniform(0.0, 6.0, 800)
    wall = np.column_stack([along, 0.01 * rng.normal(size=800)])
    other = np.column_stack([along, 1.2 + 0.01 * rng.normal(size=800)])
    cross = np.column_stack([3.0 + 0.01 * rng.normal(size=300), rng.uniform(-2.0, 2.0, 300)])
    clutter = rng.uniform(-4.0, 8.0, (200, 2))
    return np.vstack([wall, other, cross, clutter])


def test_the_lines_are_the_k_d_trees_neighbourhoods():
    cloud = _cloud(2)
    means = np.unique(np.round(cloud / 0.025), axis=0) * 0.025
    centres, normals = neighbourhood_lines(means, cloud, 0.2, 64, 8, 0.5)
    distances, neighbours = cKDTree(cloud).query(means, k=64, distance_upper_bound=0.2)
    lines = 0
    for m in range(len(means)):
        near = neighbours[m][np.isfinite(distances[m])]
        if len(near) < 8:
            assert np.isnan(normals[m]).all() and np.array_equal(centres[m], means[m])
            continue
        values, vectors = np.linalg.eigh(np.cov(cloud[near].T, bias=True))
        if values[0] > 0.25 * values[1]:
            assert np.isnan(normals[m]).all()
            continue
        lines += 1
        assert np.allclose(centres[m], cloud[near].mean(axis=0), atol=1e-12)
        assert abs(abs(float(normals[m] @ vectors[:, 0])) - 1.0) < 1e-9
    assert lines > len(means) // 2
