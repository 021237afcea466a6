"""Rooms whose four-fold symmetry one feature breaks: the free-path check sees a beam go through a
doorway where the likelihood field does not. The closed loop in such rooms:
tests/evaluation/test_symmetry_closed_loop.py; figures over the generated families: bench/bench_localization.py
--symmetry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_localization.distance_field import DistanceField
from amr_localization.likelihood_field import LikelihoodField, LikelihoodFieldParams
from amr_localization.scan_beams import Beams
from amr_localization.sensor_mount import SensorMount
from amr_maps.occupancy_grid import OCCUPIED, OccupancyGrid


def _beam(range_, angle, returned=True):
    return Beams(np.array([range_]), np.array([angle]), np.array([returned]), 3.5, np.array([0]), 0.01)


def test_the_free_path_check_sees_a_beam_go_through_a_wall_where_the_likelihood_field_does_not():
    data = np.zeros((100, 100), dtype=np.int8)  # 2 m x 2 m at 2 cm; a wall 4 cm thick at x = 1.0 m
    data[:, 50:52] = OCCUPIED
    data[[0, -1], :] = OCCUPIED
    data[:, [0, -1]] = OCCUPIED
    model = LikelihoodField(DistanceField(OccupancyGrid(data, 0.02)), LikelihoodFieldParams(), SensorMount(), 3.5)
    pose = np.array([[0.5, 1.0, 0.0]])  # 0.5 m left of the wall, facing it
    hit, through = _beam(0.51, 0.0), _beam(1.49, 0.0)  # ends on the wall; on the far outer wall, behind it
    assert model.log_likelihood(pose, through)[0] == pytest.approx(model.log_likelihood(pose, hit)[0])
    assert model.log_likelihood_free_path(pose, through, 0.1)[0] == pytest.approx(math.log(0.1 / 3.5), abs=1e-5)
    assert model.log_likelihood_free_path(pose, hit, 0.1)[0] == pytest.approx(model.log_likelihood(pose, hit)[0])
    grazing = np.array([[0.5, 0.6, math.radians(88.0)]])  # nearly along the wall's left face, ends on the top wall
    assert model.log_likelihood_free_path(grazing, _beam(1.36, 0.0), 0.1)[0] == pytest.approx(
        model.log_likelihood(grazing, _beam(1.36, 0.0))[0], abs=1e-5
    )
    assert model.log_likelihood_free_path(pose, _beam(3.5, 0.0, returned=False), 0.1)[0] == pytest.approx(
        math.log(0.1 / 3.5), abs=1e-5
    ), "no return, though a wall stands 0.5 m ahead"
    assert model.log_likelihood_free_path(np.array([[0.5, 1.0, math.pi / 2]]), _beam(3.5, 0.0, returned=False), 0.1)[
        0
    ] == pytest.approx(math.log(0.1 / 3.5), abs=1e-5)  # the top wall
    open_room = np.zeros((300, 300), dtype=np.int8)
    open_room[0, :] = OCCUPIED
    far = LikelihoodField(DistanceField(OccupancyGrid(open_room, 0.02)), LikelihoodFieldParams(), SensorMount(), 3.5)
    assert (
        far.log_likelihood_free_path(np.array([[3.0, 3.0, math.pi / 2]]), _beam(3.5, 0.0, returned=False), 0.1)[0]
        == 0.0
    ), "no return and nothing within range: nothing to say"


def test_the_best_free_path_over_nudges_is_the_best_of_each_nudged_pose_traced():
    """best_free_path traces a beam's nudged poses in order of their end point's term and stops at the first free
    one: the same per-beam maximum as tracing every nudged pose (through walls, along them, no return)."""
    rng = np.random.default_rng(3)
    data = np.zeros((120, 160), dtype=np.int8)  # 2.4 m x 3.2 m at 2 cm: outer walls, an inner wall with a doorway
    data[[0, -1], :] = OCCUPIED
    data[:, [0, -1]] = OCCUPIED
    data[:, 80:82] = OCCUPIED
    data[50:70, 80:82] = 0
    data[rng.random(data.shape) < 0.01] = OCCUPIED  # clutter
    model = LikelihoodField(DistanceField(OccupancyGrid(data, 0.02)), LikelihoodFieldParams(), SensorMount(0.05), 3.5)
    count = 60
    angles = np.linspace(-math.pi, math.pi, count, endpoint=False)
    returned = rng.random(count) < 0.9
    beams = Beams(rng.uniform(0.2, 3.4, count), angles, returned, 3.5, np.arange(count), 0.01)
    poses = np.column_stack([rng.uniform(0.1, 3.1, 40), rng.uniform(0.1, 2.3, 40), rng.uniform(-3.1, 3.1, 40)])
    nudges = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)]) * [0.02, 0.02, 0.01]
    best = model.best_free_path(poses, nudges, beams, 0.1)
    traced = np.stack([model.log_likelihood_free_path(poses + nudge, beams, 0.1, per_beam=True) for nudge in nudges])
    see_through = math.log(0.1 / 3.5)
    assert np.isclose(traced, see_through, atol=1e-5).any(axis=0).sum() > 100, "beams through walls, some nudges"
    assert (best > traced[len(nudges) // 2]).sum() > 100, "the nudges matter: the pose itself scores less"
    np.testing.assert_array_equal(best, traced.max(axis=0))


def test_fixed_poses_score_as_best_free_path_with_their_paths_kept():
    """FixedPoses keeps each nudged beam's exit through a wall per beam (its angle): scans with other beams and other
    ranges, some beams seen before, score exactly as best_free_path traces them, and a kept exit is read, not traced
    again (a wrong kept value shows)."""
    rng = np.random.default_rng(4)
    data = np.zeros((120, 160), dtype=np.int8)
    data[[0, -1], :] = OCCUPIED
    data[:, [0, -1]] = OCCUPIED
    data[:, 80:82] = OCCUPIED
    data[50:70, 80:82] = 0
    data[rng.random(data.shape) < 0.01] = OCCUPIED
    model = LikelihoodField(DistanceField(OccupancyGrid(data, 0.02)), LikelihoodFieldParams(), SensorMount(0.05), 3.5)
    poses = np.column_stack([rng.uniform(0.1, 3.1, 30), rng.uniform(0.1, 2.3, 30), rng.uniform(-3.1, 3.1, 30)])
    nudges = np.array([(i, j, k) for k in (-1, 0, 1) for i in (-1, 0, 1) for j in (-1, 0, 1)]) * [0.02, 0.02, 0.01]
    fixed = model.fixed_poses(poses, nudges)
    scan = np.linspace(-math.pi, math.pi, 180, endpoint=False)
    for _ in range(4):
        index = np.sort(rng.choice(180, 60, replace=False))
        returned = rng.random(60) < 0.9
        beams = Beams(rng.uniform(0.2, 3.4, 60), scan[index], returned, 3.5, index - index[0], scan[1] - scan[0])
        np.testing.assert_array_equal(fixed.best_free_path(beams, 0.1), model.best_free_path(poses, nudges, beams, 0.1))
    kept = fixed._table
    assert np.isfinite(kept).sum() > 1000 and np.isnan(kept).sum() > 1000, "exits kept as traced, the rest not yet"
    kept[np.isfinite(kept)] = 0.0  # every kept exit made wrong: at the sensor
    assert (fixed.best_free_path(beams, 0.1) != model.best_free_path(poses, nudges, beams, 0.1)).any()
