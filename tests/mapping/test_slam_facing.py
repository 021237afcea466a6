"""The front end's window keeps only the surfaces facing where the next scan is taken (slam._facing): a thin
wall's far face, seen by earlier scans from the other side, is where that scan can have no point, and pairing with
it pulled the mazes' links towards it (the per-link error against the simulator's truth)."""

from __future__ import annotations

import numpy as np

from amr_mapping.slam import _facing

THICKNESS = 0.055
"""m: the generated mazes' walls."""


def _faces(rng, count: int = 120, noise: float = 0.01):
    """A thin wall along x: its lower face (y = 0) seen from (x, -1), its upper face (y = THICKNESS) from (x, 1)."""
    x = rng.uniform(-1.0, 1.0, count)
    lower = np.column_stack([x, rng.normal(0.0, noise, count)])
    upper = np.column_stack([x, THICKNESS + rng.normal(0.0, noise, count)])
    cloud = np.vstack([lower, upper])
    sensors = np.vstack([np.column_stack([x, np.full(count, -1.0)]), np.column_stack([x, np.full(count, 1.0)])])
    return cloud, sensors


def test_a_thin_walls_far_face_is_left_out():
    cloud, sensors = _faces(np.random.default_rng(0))
    keep = _facing(cloud, sensors, (0.3, -0.8), 0.05)
    lower, upper = keep[:120], keep[120:]
    assert lower.mean() > 0.95, lower.mean()
    assert upper.mean() < 0.05, upper.mean()
    keep = _facing(cloud, sensors, (-0.2, 0.9), 0.05)  # from the other side: the other face
    assert keep[:120].mean() < 0.05 and keep[120:].mean() > 0.95


def test_surfaces_without_a_line_are_kept():
    """A lone point or a corner has no normal to judge by: kept, as the window had it."""
    cloud = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, -1.0]])
    sensors = np.array([[0.0, -1.0], [1.0, 2.0], [2.0, 0.0]])
    assert _facing(cloud, sensors, (0.0, 5.0), 0.05).all()
