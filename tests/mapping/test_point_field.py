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


def _thin_wall(seed: int = 0):
    """A wall 5.5 cm thick along x (faces at y = +-0.0275), its top face seen from (0, 0.7) and its bottom face from
    (0, -0.7), 1 cm of noise: the points, where each was seen from, and the voxel means with the mean of those."""
    rng = np.random.default_rng(seed)
    xs = rng.uniform(-1.0, 1.0, 400)
    top = np.column_stack([xs[:200], 0.0275 + 0.01 * rng.normal(size=200)])
    bottom = np.column_stack([xs[200:], -0.0275 + 0.01 * rng.normal(size=200)])
    cloud = np.vstack([top, bottom])
    sensors = np.vstack([np.tile([0.0, 0.7], (200, 1)), np.tile([0.0, -0.7], (200, 1))])
    keys = np.round(cloud / 0.025).astype(int) * 2 + (sensors[:, 1] > 0)[:, None]  # a square and a side
    _, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.reshape(-1)
    count = np.bincount(group)
    means = np.column_stack([np.bincount(group, weights=cloud[:, i]) / count for i in range(2)])
    mean_sensors = np.column_stack([np.bincount(group, weights=sensors[:, i]) / count for i in range(2)])
    return cloud, sensors, means, mean_sensors


def test_with_its_sensors_each_face_of_a_thin_wall_is_its_own_line_facing_them():
    """Both faces lie within the neighbourhood's 0.2 m: without the sensors a mean's line runs between them (its
    centroid up to half the thickness off its face); with them, the neighbours seen from the other side are left out
    and the normal points to the side the mean was seen from."""
    cloud, sensors, means, mean_sensors = _thin_wall()
    faces = np.where(mean_sensors[:, 1] > 0, 0.0275, -0.0275)
    centres, normals = neighbourhood_lines(means, cloud, 0.2, 64, 8, 0.5, sensors, mean_sensors)
    lines = np.isfinite(normals[:, 0])
    assert lines.mean() > 0.9
    assert np.abs(centres[lines, 1] - faces[lines]).max() < 0.006
    assert np.all(normals[lines, 1] * faces[lines] > 0.99 * 0.0275)  # towards the sensor's side
    mixed, _ = neighbourhood_lines(means, cloud, 0.2, 64, 8, 0.5)
    assert np.median(np.abs(mixed[lines, 1] - faces[lines])) > 0.01
