"""The particle filter end to end: global localization while wall following, symmetry, kidnapping,
determinism and bad input. Figures over many worlds and seeds: bench/bench_localization.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.localization import ROOT, WORLDS_DIR, odometry_of

from amr_control.wall_follower_config import read_parameter_file
from amr_evaluation.closed_loop import run
from amr_localization.beacons import BeaconReading
from amr_localization.errors import LocalizationError
from amr_localization.particle_filter import ParticleFilter
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid
from amr_maps.rasterize import rasterize_world as grid_of
from amr_maps.world import load_world, world_from_dict
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.parameter_spec import ConfigError
from amr_util.scan import ScanData, scan_of

FOLLOWER = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
CONFIG = ParticleFilterConfig(lidar_x=-0.032)
NOISY = dict(seed=3, lidar=LidarConfig(noise_std=0.02), encoders=EncoderConfig(noise=0.02, slip=0.05))


def loop(world, seconds, config=CONFIG, **kwargs):
    sim = Simulator(world, SimulationConfig(dt=FOLLOWER.dt, **NOISY))
    pf = ParticleFilter(grid_of(world, 0.02), config, range_max=sim.lidar.range_max)
    return run(sim, pf, FOLLOWER, seconds, **kwargs)


def test_globally_localizes_in_the_seed_maze_within_a_minute_and_stays_accurate():
    trace = loop(load_world(WORLDS_DIR / "inner_maze.yaml"), 40.0)
    t, localized, position, heading = trace.arrays()
    first = trace.first_localized()
    assert first is not None and t[first] <= 30.0
    assert position[first] <= 0.10 and heading[first] <= math.radians(10)
    assert localized[first:].all()
    assert np.sqrt(np.mean(position[first:] ** 2)) <= 0.03
    assert np.sqrt(np.mean(heading[first:] ** 2)) <= math.radians(2)


def test_a_hand_built_grid_map_localizes_the_robot_driving_in_the_same_grid_world():
    rows = [
        "####################",
        "#..................#",
        "#..................#",
        "#....####..........#",
        "#....####.....##...#",
        "#.............##...#",
        "#..................#",
        "#..........#########",
        "#..........#########",
        "####################",
    ]
    world = world_from_dict({"grid": {"cell_size": 0.2, "origin": [0.0, 0.0], "rows": rows}, "start": [0.5, 0.5, 0.0]})
    data = np.array([[OCCUPIED if c == "#" else 0 for c in row] for row in reversed(rows)], dtype=np.int8)
    grid = OccupancyGrid(np.kron(data, np.ones((10, 10), dtype=np.int8)), 0.02)  # the same map at 2 cm
    sim = Simulator(world, SimulationConfig(dt=FOLLOWER.dt, **NOISY))
    trace = run(sim, ParticleFilter(grid, CONFIG, range_max=3.5), FOLLOWER, 40.0)
    first = trace.first_localized()
    assert first is not None
    _, _, position, heading = trace.arrays()
    assert position[first] <= 0.10 and heading[first] <= math.radians(10)


def test_two_identical_rooms_are_never_taken_for_one():
    trace = loop(load_world(WORLDS_DIR / "twin_rooms.yaml"), 60.0)
    assert trace.first_localized() is None


def test_a_kidnapped_robot_is_withdrawn_at_once_and_found_again():
    trace = loop(load_world(WORLDS_DIR / "inner_maze.yaml"), 80.0, kidnap=(20.0, (-1.0, 1.0, 0.0)))
    t, localized, position, heading = trace.arrays()
    kidnapped = trace.kidnapped_at
    assert localized[np.flatnonzero(t < kidnapped)[-1]], "it was localized before the kidnapping"
    withdrawn = np.flatnonzero((t >= kidnapped) & ~localized)
    assert withdrawn.size and t[withdrawn[0]] - kidnapped <= 10.0
    regained = trace.first_localized(after=t[withdrawn[0]])
    assert regained is not None and t[regained] - kidnapped <= 60.0
    assert position[regained] <= 0.10 and heading[regained] <= math.radians(10)


def test_a_robot_kidnapped_into_a_look_alike_place_is_withdrawn_within_10_s():
    """hard_maze: the place it is carried to fits the scan at the old estimate nearly as well."""
    world = load_world(WORLDS_DIR / "hard_maze.yaml")
    sim = Simulator(
        world,
        SimulationConfig(
            dt=FOLLOWER.dt, seed=0, lidar=LidarConfig(noise_std=0.02), encoders=EncoderConfig(noise=0.02, slip=0.03)
        ),
    )
    pf = ParticleFilter(grid_of(world, 0.02), ParticleFilterConfig(lidar_x=-0.032), range_max=sim.lidar.range_max)
    trace = run(sim, pf, FOLLOWER, 45.0, kidnap=(30.0, (-1.3, 1.25, 0.0)))
    t, localized, _, _ = trace.arrays()
    assert localized[np.flatnonzero(t < trace.kidnapped_at)[-1]], "it was localized before the kidnapping"
    withdrawn = np.flatnonzero((t >= trace.kidnapped_at) & ~localized)
    assert withdrawn.size and t[withdrawn[0]] - trace.kidnapped_at <= 10.0


def test_a_confident_wrong_pose_the_scans_do_not_fit_is_given_up_for_the_true_place():
    world = load_world(WORLDS_DIR / "open_room.yaml")
    sim = Simulator(world, SimulationConfig(**NOISY))
    config = ParticleFilterConfig(lidar_x=-0.032, max_particles=2000)
    pf = ParticleFilter(grid_of(world, 0.02), config)
    pf.initialize_pose(sim.pose.x + 0.8, sim.pose.y + 0.5, sim.pose.theta + 1.5, np.diag([0.02**2, 0.02**2, 0.02**2]))
    errors = []
    for _ in range(400):
        estimate = pf.update(odometry_of(sim), scan_of(sim))
        errors.append((math.hypot(estimate.pose.x - sim.pose.x, estimate.pose.y - sim.pose.y), estimate.localized))
        sim.step(0.12, 0.25)
    assert not any(localized for error, localized in errors[:5] if error > 0.5) or errors[-1][0] <= 0.1
    assert errors[-1][0] <= 0.1 and errors[-1][1], f"not found again: {errors[-1]}"


def _first_steps(seed: int, steps: int = 60):
    world = load_world(WORLDS_DIR / "open_room.yaml")
    sim = Simulator(world, SimulationConfig(**NOISY))
    pf = ParticleFilter(grid_of(world, 0.05), ParticleFilterConfig(lidar_x=-0.032, max_particles=1000, seed=seed))
    poses = []
    for _ in range(steps):
        estimate = pf.update(odometry_of(sim), scan_of(sim))
        poses.append((estimate.pose.x, estimate.pose.y, estimate.pose.theta, estimate.localized))
        sim.step(0.15, 0.3)
    return poses, pf.particles


def test_same_seed_and_inputs_give_the_same_estimates():
    first, particles = _first_steps(seed=7)
    again, particles_again = _first_steps(seed=7)
    other, particles_other = _first_steps(seed=8)
    assert first == again
    np.testing.assert_array_equal(particles, particles_again)
    assert not np.array_equal(particles[:, :2], particles_other[:, :2]) or first != other


def test_bad_input_is_refused_with_its_name_and_the_filter_carries_on():
    world = load_world(WORLDS_DIR / "open_room.yaml")
    sim = Simulator(world, SimulationConfig())
    pf = ParticleFilter(grid_of(world, 0.05), ParticleFilterConfig(max_particles=500, lidar_x=-0.032))
    good = scan_of(sim)
    pf.update(odometry_of(sim), good)
    for odometry in [(math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (0.0, 0.0)]:
        with pytest.raises(LocalizationError, match="odometry"):
            pf.update(odometry, good)
    with pytest.raises(LocalizationError, match="angle_increment"):
        pf.update(odometry_of(sim), ScanData(good.ranges, 0.0, math.nan, 0.12, 3.5))
    with pytest.raises(LocalizationError, match="without beacon"):
        pf.update(odometry_of(sim), beacons=BeaconReading(np.array([1.0]), 0.0))
    blind = pf.update(odometry_of(sim), ScanData(np.full(240, np.nan), 0.0, good.angle_increment, 0.12, 3.5))
    assert "no valid return" in blind.status.event and np.isfinite([blind.pose.x, blind.pose.y, blind.pose.theta]).all()
    jump = pf.update((5.0, 0.0, 0.0), good)
    assert "odometry jumped" in jump.status.event
    assert (jump.pose.x, jump.pose.y) == pytest.approx((blind.pose.x, blind.pose.y))
    short = pf.update((5.05, 0.0, 0.0), ScanData([1.0, 2.0], 0.0, 0.1, 0.12, 3.5))  # two beams: used, no crash
    assert np.isfinite(short.pose.covariance).all()
    for params, key in [
        ({"max_particles": 10, "min_particles": 100}, "max_particles"),
        ({"laser_model_type": "sonar"}, "laser_model_type"),
        ({"sigma_hit": -1.0}, "sigma_hit"),
        ({"nonsense": 1}, "nonsense"),
    ]:
        with pytest.raises(ConfigError, match=key):
            ParticleFilterConfig.from_params(params)
    with pytest.raises(LocalizationError, match="no free cell"):
        ParticleFilter(OccupancyGrid(np.full((30, 30), UNKNOWN, dtype=np.int8), 0.05))
    with pytest.raises(LocalizationError, match="beacons: the list is empty"):
        ParticleFilter(grid_of(world, 0.05), beacons=[])


def test_an_initial_pose_tracks_from_there():
    world = load_world(WORLDS_DIR / "open_room.yaml")
    sim = Simulator(world, SimulationConfig(**NOISY))
    pf = ParticleFilter(grid_of(world, 0.02), ParticleFilterConfig(lidar_x=-0.032))
    pf.initialize_pose(sim.pose.x + 0.1, sim.pose.y - 0.1, sim.pose.theta + 0.1, np.diag([0.1**2, 0.1**2, 0.1**2]))
    for _ in range(200):
        estimate = pf.update(odometry_of(sim), scan_of(sim))
        sim.step(0.1, 0.2)
    assert estimate.localized
    assert math.hypot(estimate.pose.x - sim.pose.x, estimate.pose.y - sim.pose.y) < 0.05
    with pytest.raises(LocalizationError, match="outside the map"):
        pf.initialize_pose(50.0, 50.0, 0.0, np.diag([0.01, 0.01, 0.01]))
