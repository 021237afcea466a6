"""The particle filter in the closed loop without ROS (amr_evaluation.closed_loop: the simulator, the wall follower
and the filter in lockstep): global localization while wall following, a hand-built map, twin rooms, kidnapping.
Figures over many worlds and seeds: bench/bench_localization.py."""

from __future__ import annotations

import math

import numpy as np
from support.localization import ROOT, WORLDS_DIR

from amr_control.wall_follower_config import read_parameter_file
from amr_evaluation.closed_loop import run
from amr_localization.particle_filter import ParticleFilter
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_maps.occupancy_grid import OCCUPIED, OccupancyGrid
from amr_maps.rasterize import rasterize_world as grid_of
from amr_maps.world import load_world, world_from_dict
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
from amr_simulation.simulator import Simulator

FOLLOWER = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
CONFIG = ParticleFilterConfig(lidar_x=-0.032)
NOISY = dict(seed=3, lidar=LidarConfig(noise_std=0.02), encoders=EncoderConfig(noise=0.02, slip=0.05))


def loop(world, seconds, config=CONFIG, **kwargs):
    sim = Simulator(world, SimulationConfig(dt=FOLLOWER.dt, **NOISY))
    pf = ParticleFilter(grid_of(world, 0.02), config, range_max=sim.lidar.range_max)
    return run(sim, pf, FOLLOWER, seconds, **kwargs)


class WithdrawnThen:
    """A run's `until`: from the kidnapping at `kidnap_time` on, true at the first withdrawn step (localized=False)
    or at the first localized step after a withdrawal (localized=True); what the kidnap tests check is decided
    there, so the run's length is only their deadline."""

    def __init__(self, kidnap_time: float, localized: bool) -> None:
        self.kidnap_time = kidnap_time
        self.localized = localized
        self.withdrawn = False

    def __call__(self, sim, estimate) -> bool:
        if sim.time < self.kidnap_time:  # run() kidnaps at the first step at or after kidnap_time
            return False
        self.withdrawn = self.withdrawn or not estimate.localized
        return self.withdrawn and estimate.localized == self.localized


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
    trace = run(sim, ParticleFilter(grid, CONFIG, range_max=3.5), FOLLOWER, 40.0, stop_when_localized=True)
    first = trace.first_localized()
    assert first is not None
    _, _, position, heading = trace.arrays()
    assert position[first] <= 0.10 and heading[first] <= math.radians(10)


def test_two_identical_rooms_are_never_taken_for_one():
    trace = loop(load_world(WORLDS_DIR / "twin_rooms.yaml"), 60.0)
    assert trace.first_localized() is None


def test_a_kidnapped_robot_is_withdrawn_at_once_and_found_again():
    until_regained = WithdrawnThen(20.0, localized=True)  # the run ends once it is localized again (80 s at most)
    trace = loop(
        load_world(WORLDS_DIR / "inner_maze.yaml"), 80.0, kidnap=(20.0, (-1.0, 1.0, 0.0)), until=until_regained
    )
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
    until_withdrawn = WithdrawnThen(30.0, localized=False)  # the run ends at the withdrawal (45 s at most)
    trace = run(sim, pf, FOLLOWER, 45.0, kidnap=(30.0, (-1.3, 1.25, 0.0)), until=until_withdrawn)
    t, localized, _, _ = trace.arrays()
    assert localized[np.flatnonzero(t < trace.kidnapped_at)[-1]], "it was localized before the kidnapping"
    withdrawn = np.flatnonzero((t >= trace.kidnapped_at) & ~localized)
    assert withdrawn.size and t[withdrawn[0]] - trace.kidnapped_at <= 10.0
