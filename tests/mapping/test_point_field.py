"""amr_mapping.point_field: the submaps' field and lines computed around the points give from_points' field and
a k-d tree's lines."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from amr_mapping.point_field import neighbourhood_lines, point_field
from amr_maps.scan_matcher import ScoreMap


def _cloud(seed: int = 0) -> np.ndarray:
    """Walls (a corridor, a crossing wall) and clutter: ties between equally near cells, lines and corners."""
    rng = np.random.default_rng(seed)
    along = rng.uniform(0.0, 6.0, 800)
    wall = np.column_stack([along, 0.01 * rng.normal(size=800)])
    other = np.column_stack([along, 1.2 + 0.01 * rng.normal(size=800)])
    cross = np.column_stack([3.0 + 0.01 * rng.normal(size=300), rng.uniform(-2.0, 2.0, 300)])
    clutter = rng.uniform(-4.0, 8.0, (200, 2))
    return np.vstack([wall, other, cross, clutter])


@pytest.mark.parametrize("seed", [0, 1])
def test_the_stamped_field_is_from_points_field_cell_for_cell(seed):
    cloud = _cloud(seed)
    expected = ScoreMap.from_points(cloud, 0.05, 0.075, 2.5, cover=np.zeros((1, 2)), to_points=True)
    field = point_field(cloud, 0.05, 0.075, 2.5, np.zeros((1, 2)))
    assert field.origin == expected.origin
    assert field.table.shape == expected.table.shape
    # the same values wherever the field is above exp(-18) (beyond, from_points' tiny values are 0 here)
    near = expected.table > 1e-7
    assert near.sum() > 10_000
    assert np.array_equal(field.table[near], expected.table[near])
    assert np.abs(field.table - expected.table).max() < 1e-7


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
