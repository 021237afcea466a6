"""Beams on objects the map lacks, weighed by the belief (amr_localization/unmapped_beams.py): the distance filter
of Fox, Burgard and Thrun 1999, each case solved by hand on a wall 0.5 m ahead of the sensor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_localization.distance_field import DistanceField
from amr_localization.likelihood_field import LikelihoodField, LikelihoodFieldParams
from amr_localization.particle_filter import ParticleFilter
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_localization.scan_beams import Beams
from amr_localization.sensor_mount import SensorMount
from amr_localization.unmapped_beams import mapped_share
from amr_maps.occupancy_grid import OCCUPIED, OccupancyGrid
from amr_maps.rasterize import rasterize_world as grid_of
from amr_maps.world import world_from_dict
from amr_simulation.config import LidarConfig, SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.scan import scan_of

MARGIN = 0.1


def _beams(ranges, returned=None):
    ranges = np.asarray(ranges, dtype=float)
    returned = np.ones(len(ranges), dtype=bool) if returned is None else np.asarray(returned)
    return Beams(ranges, np.zeros(len(ranges)), returned, 3.5, np.arange(len(ranges)), 0.01)


@pytest.fixture(scope="module")
def model():
    data = np.zeros((100, 100), dtype=np.int8)  # 2 m x 2 m at 2 cm; a wall 4 cm thick at x = 1.0 m
    data[:, 50:52] = OCCUPIED
    data[[0, -1], :] = OCCUPIED
    data[:, [0, -1]] = OCCUPIED
    return LikelihoodField(DistanceField(OccupancyGrid(data, 0.02)), LikelihoodFieldParams(), SensorMount(), 3.5)


def test_a_beam_is_short_where_its_path_is_clear_and_no_wall_is_within_the_pose_s_error_past_its_end(model):
    pose = np.array([[0.5, 1.0, 0.0]])  # facing the wall 0.5 m ahead
    beams = _beams([0.3, 0.51, 1.49, 3.5], returned=[True, True, True, False])
    # short of the wall; on it; through it; no return
    np.testing.assert_array_equal(model.clear_path(pose, beams, MARGIN), [[True, False, False, False]])
    # a pose 0.25 m off along the beam could put the wall at the 0.3 m beam's end: not short then
    np.testing.assert_array_equal(model.clear_path(pose, beams, MARGIN, 0.25), [[False, False, False, False]])
    np.testing.assert_array_equal(model.clear_path(pose, beams, MARGIN, 0.1), [[True, False, False, False]])
    assert model.floor == pytest.approx(math.log(0.1 / 3.5), abs=1e-5)


def test_a_beam_the_believed_place_calls_short_is_left_out_only_where_that_place_is_all_but_certain(model):
    short_here = np.array([0.5, 1.0, 0.0])  # a 0.2 m beam ends 0.3 m short of the wall: an object the map lacks
    wall_there = np.array([0.81, 1.0, 0.0])  # the same beam ends on the wall: the map explains it
    beams = _beams([0.2])
    poses = np.array([short_here, wall_there])
    terms = model.best_free_path(poses, np.zeros((1, 3)), beams, MARGIN)
    clear = model.clear_path(poses, beams, MARGIN)
    assert terms[0, 0] == pytest.approx(model.floor, abs=1e-5) and terms[1, 0] > model.floor + 4.0
    hit_random = math.exp(model.floor - terms[1, 0])  # the wall place's own share of a random reading: 0.004
    assert hit_random < 0.01
    # P(unmodelled) = 0.995 + 0.004 x 0.004 > 0.99: left out; 0.98 (or a belief split, or `elsewhere` holding the
    # rest) is not certain enough: the beam counts whole
    for belief, share in (([0.995, 0.004], 0.0), ([0.98, 0.02], 1.0), ([0.5, 0.5], 1.0), ([0.5, 0.0], 1.0)):
        assert mapped_share(np.array(belief), terms, clear, model.floor)[0] == share, belief
    assert mapped_share(np.zeros(0), terms[:0], clear[:0], model.floor).tolist() == [1.0]


def test_a_beam_through_the_believed_place_s_wall_keeps_its_whole_weight(model):
    """An object only shortens a beam: a beam seen through the believed place's wall is the map's word against that
    place (a kidnapped robot's first evidence), never discounted."""
    pose = np.array([[0.5, 1.0, 0.0]])
    beams = _beams([1.49])
    terms = model.best_free_path(pose, np.zeros((1, 3)), beams, MARGIN)
    assert terms[0, 0] == pytest.approx(model.floor, abs=1e-5)
    assert mapped_share(np.array([1.0]), terms, model.clear_path(pose, beams, MARGIN), model.floor)[0] == 1.0


def _rooms(pillars):
    """Two 1.6 x 1.2 m rooms 2.4 m apart, each with a notch (alone, neither is symmetric); the second a translated copy
    of the first with a 14 cm pillar 0.45 m ahead of its middle; `pillars`: the rooms (0, 1) that have it."""

    def room(x0):
        corners = [[x0, 0.0], [x0 + 1.6, 0.0], [x0 + 1.6, 1.2], [x0, 1.2]]
        return [[*corners[i], *corners[(i + 1) % 4]] for i in range(4)] + [[x0 + 0.3, 0.0, x0 + 0.3, 0.25]]

    boxes = [[2.4 * i + 1.18, 0.53, 2.4 * i + 1.32, 0.67] for i in pillars]
    return {
        "name": "rooms",
        "wall_thickness": 0.04,
        "walls": room(0.0) + room(2.4),
        "boxes": boxes,
        "start": [0.8, 0.6, 0.0],
    }


@pytest.mark.parametrize("seed", [0, 1])
def test_a_robot_tracked_beside_an_object_the_map_lacks_keeps_its_place_over_a_look_alike_with_a_wall_there(seed):
    """The robot turns to and fro in the first room beside something the map lacks (another robot), standing where
    the second room, else its copy, has its pillar: every scan is explained better by the second room, by that
    object's beams alone. They are beams the believed (all but certain) place calls short: left out of the odds
    (before the distance filter: the look-alike declared 2.4 m off within 3 s)."""
    sim = Simulator(world_from_dict(_rooms((0, 1))), SimulationConfig(seed=seed, lidar=LidarConfig(noise_std=0.01)))
    pf = ParticleFilter(grid_of(world_from_dict(_rooms((1,))), 0.02), ParticleFilterConfig(seed=seed, lidar_x=-0.032))
    pf.initialize_pose(sim.pose.x, sim.pose.y, sim.pose.theta, np.diag([0.01**2, 0.01**2, 0.01**2]))
    localized, look_alike_seen = 0, False
    for step in range(200):
        estimate = pf.update(tuple(sim.odom_pose), scan_of(sim), stamp=step * 0.05)
        look_alike_seen |= bool((pf.hypotheses.poses[:, 0] > 2.4).any())
        if estimate.localized:
            localized += 1
            assert math.hypot(estimate.pose.x - sim.pose.x, estimate.pose.y - sim.pose.y) < 0.1, f"step {step}"
        sim.step(0.0, 0.6 if step < 100 else -0.6)
    assert look_alike_seen, "the place search proposed the second room: the odds were put to the test"
    assert localized > 150
