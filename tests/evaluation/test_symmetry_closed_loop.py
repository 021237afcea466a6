"""Rooms whose four-fold symmetry one feature breaks, in the closed loop without ROS (amr_evaluation.closed_loop):
localized soon after the feature is seen, and a truly symmetric room never declared. Figures over the generated
families: bench/bench_localization.py --symmetry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.localization import ROOT

from amr_control.wall_follower_config import read_parameter_file
from amr_evaluation import configs
from amr_evaluation.closed_loop import run
from amr_evaluation.episode import EpisodeSpec, run_episode
from amr_localization.distance_field import DistanceField
from amr_localization.particle_filter import ParticleFilter
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_maps.rasterize import rasterize_world as grid_of
from amr_maps.symmetry_families import FeatureView, symmetry_case
from amr_maps.world import world_from_dict
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
from amr_util.robot_description import default_robot

FOLLOWER = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
NOISY = dict(lidar=LidarConfig(noise_std=0.02), encoders=EncoderConfig(noise=0.02, slip=0.03))


def _simulator(world, seed=3):
    from amr_simulation.simulator import Simulator

    return Simulator(world, SimulationConfig(dt=FOLLOWER.dt, seed=seed, **NOISY))


def _closed_loop(case_world, seconds, max_particles=5000, seed=3):
    world = world_from_dict(case_world)
    sim = _simulator(world, seed)
    config = ParticleFilterConfig(lidar_x=-0.032, max_particles=max_particles, seed=seed)
    pf = ParticleFilter(grid_of(world, 0.02), config, range_max=sim.lidar.range_max)
    return sim, run(sim, pf, FOLLOWER, seconds, stop_when_localized=True)


@pytest.mark.parametrize("kind, seed", [("doorway", 1), ("extra_pillar", 0), ("notch", 1)])
def test_a_room_one_feature_tells_apart_is_localized_soon_after_the_feature_is_seen(kind, seed):
    case = symmetry_case(kind, seed)
    sim, trace = _closed_loop(case.world, 30.0)
    first = trace.first_localized()
    assert first is not None, "not localized in 30 s"
    t, _, position, heading = trace.arrays()
    assert position[first] <= 0.10 and heading[first] <= math.radians(10)
    view = FeatureView(world_from_dict(case.world), world_from_dict(case.symmetric))
    lidar = sim.lidar
    apart = np.array(
        [
            view.told_apart(
                x + lidar.x * math.cos(th),
                y + lidar.x * math.sin(th),
                th,
                lidar.angle_increment,
                lidar.beams,
                lidar.range_max,
            )
            for x, y, th in trace.truth[: first + 1]
        ]
    )
    # a quarter turn is also told apart where the turned pose is no place for the robot (its footprint on the
    # feature): the feature then sits under the LiDAR's range_min, and the ranges alone cannot show it
    field = DistanceField(grid_of(world_from_dict(case.world), 0.02))

    def distance_at(x, y):
        row, col = field.grid.world_to_cell(np.array([x]), np.array([y]))
        return float(field.distances[row[0], col[0]])

    clearance = np.array(
        [
            [
                distance_at(
                    math.cos(k * math.pi / 2) * x - math.sin(k * math.pi / 2) * y,
                    math.sin(k * math.pi / 2) * x + math.cos(k * math.pi / 2) * y,
                )
                for k in (1, 2, 3)
            ]
            for x, y, _ in trace.truth[: first + 1]
        ]
    )
    impossible = (clearance < default_robot().radius).any(axis=0)
    assert ((apart.max(axis=0) >= 3) | impossible).all(), "declared before the scans had told every quarter turn apart"


def test_a_truly_symmetric_room_mapped_off_the_lattice_is_never_declared():
    sim, trace = _closed_loop(symmetry_case("island", 0, lattice=False).world, 25.0, max_particles=1000)
    assert trace.first_localized() is None


def test_before_the_feature_is_seen_no_copy_of_the_room_is_declared():
    # missing_pillar 5 as bench_localization --symmetry runs it (its episode, its noise): the particles' cluster at
    # the truth was 12 cm and 3 deg off at the first scan; scored there, its place started 35 nats under the copies
    # the place search proposed at their best poses, and a quarter turn was declared 3.8 m off within 0.5 s
    case = symmetry_case("missing_pillar", 5)
    label, parameters = configs.resolve("localization", "default")
    spec = EpisodeSpec(
        "localization",
        label,
        parameters,
        {"data": case.world, "name": case.world["name"]},
        None,
        5,
        0.017490531316711234,
        0.01831522864576864,
        0.02558639217132215,
        20.0,  # the feature comes into view after 31 s
        {"symmetric": case.symmetric, "stop_after": 15.0},
    )
    record = run_episode(spec)
    assert record["error"] is None
    if record["time_to_localized"] is not None:
        assert record["localization_error"] <= 0.10 and record["extra"]["heading_error"] <= 10.0
