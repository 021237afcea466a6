"""Rooms whose four-fold symmetry one feature breaks (issue 20): the free-path check sees a beam go through a
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
