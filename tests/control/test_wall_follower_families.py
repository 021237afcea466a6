"""The wall follower on generated geometry: bends of any angle, narrowing corridors under noise, open space, outliers.

Closed loop through the library (test_closed_loop.run_loop) on amr_maps.maze_families
worlds kept small so each run lasts seconds; the sweeps over families, seeds and noise are in
bench/bench_wall_follower_families.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.closed_loop import REAL_CONFIG, SIM_CONFIG, run_loop
from support.control import cast, corridor

from amr_control.scan_sectors import Footprint, ScanData, SectorReader, Sectors
from amr_control.wall_follower import WallFollower
from amr_maps.maze_families import generate
from amr_maps.world import world_from_dict
from amr_simulation.config import EncoderConfig, LidarConfig

SECTORS = Sectors(math.radians(15.0), math.radians(20.0), math.radians(5.0))
FOOTPRINT = Footprint(radius=0.105, lidar_x=-0.032)


def test_a_lone_outlier_beam_is_replaced_and_clean_beams_kept_exactly():
    clean = cast(corridor(left=0.25, right=0.3, front=0.8))
    spiked = np.array(clean.ranges)
    spiked[0] = 0.13  # a spurious return straight ahead
    spiked[60] = np.inf  # a dropped return abeam left
    scan = ScanData(spiked, clean.angle_min, clean.angle_increment, clean.range_min, clean.range_max)
    filtered = SectorReader(SECTORS, FOOTPRINT, median_beams=3)
    assert SectorReader(SECTORS, FOOTPRINT).read(scan).front == pytest.approx(0.13)  # unfiltered: a false block
    r = filtered.read(scan)
    assert r.front == pytest.approx(0.8, abs=1e-3) and r.left_abeam == pytest.approx(0.25, abs=1e-3)
    assert filtered.read(clean) == SectorReader(SECTORS, FOOTPRINT).read(clean)  # no outlier: nothing changes


def test_free_travel_is_measured_from_the_rotation_centre_in_every_direction():
    reader = SectorReader(SECTORS, FOOTPRINT)
    reader.read(cast(corridor(left=0.2, right=0.3, front=0.5)))
    ahead, left, right = reader.free_travel(np.array([0.0, math.pi / 2, -math.pi / 2]))
    assert ahead == pytest.approx(0.5 - 0.032 - 0.105, abs=2e-3)  # the centre is 3.2 cm nearer than the LiDAR
    assert left == pytest.approx(0.2 - 0.105, abs=2e-3)
    assert right == pytest.approx(0.3 - 0.105, abs=2e-3)


def test_the_followed_wall_is_lost_only_past_the_hysteresis():
    follower = WallFollower(SIM_CONFIG)
    follower.compute(cast(corridor(left=1.0, right=0.2)), 0.0, 0.0, 0.0)
    assert follower.state == "FOLLOW"
    follower.compute(cast(corridor(left=1.0, right=0.42)), 0.15, 0.0, 0.05)  # past 0.4, within 0.43
    assert follower.state == "FOLLOW"
    follower.compute(cast(corridor(left=1.0, right=0.45)), 0.15, 0.0, 0.1)
    assert follower.state == "CORNER"


def test_a_narrow_corridor_is_followed_down_its_middle():
    follower = WallFollower(SIM_CONFIG)
    follower.compute(cast(corridor(left=0.15, right=0.15)), 0.0, 0.0, 0.0)
    command = follower.compute(cast(corridor(left=0.15, right=0.15)), 0.15, 0.0, 0.05)
    assert follower.state == "FOLLOW" and command.w == pytest.approx(0.0, abs=1e-3)  # not pushed to 0.2 m


@pytest.mark.parametrize(
    "bend_deg",
    [
        45.0,
        60.0,
        120.0,
        160.0,
    ],
)
def test_bends_of_any_angle_are_followed_never_turned_back(bend_deg):
    world = world_from_dict(generate("bends", 1, bend_deg=bend_deg, bends=2, width=0.4))
    result = run_loop(world, SIM_CONFIG, seconds=200.0)
    assert result.collisions == 0
    assert result.goal, f"missed after {result.time:.0f} s, states {dict(result.states)}"
    assert result.states["TURN_AROUND"] == 0, "a bend was taken for a dead end"


@pytest.mark.parametrize("config", [SIM_CONFIG, REAL_CONFIG], ids=["sim", "real"])
def test_a_narrowing_corridor_is_driven_through_at_lidar_noise_3_cm(config):
    world = world_from_dict(generate("narrowing", 2, max_width=0.6, min_width=0.35))
    result = run_loop(
        world,
        config,
        seconds=300.0,
        seed=3,
        lidar=LidarConfig(noise_std=0.03),
        encoders=EncoderConfig(noise=0.02, slip=0.05),
    )
    assert result.collisions == 0
    assert result.goal, f"missed after {result.time:.0f} s, states {dict(result.states)}"


def test_from_open_space_it_drives_to_a_wall_and_follows_it():
    data = generate("open_room", 4, size=5.0)
    data["start"] = [0.3, -0.2, math.radians(135.0)]  # middle of the room, diagonal heading
    data.pop("goal")
    result = run_loop(world_from_dict(data), SIM_CONFIG, seconds=120.0)
    assert result.collisions == 0
    total = sum(result.states.values())
    assert result.states["SEARCH"] / total < 0.15, dict(result.states)
    assert result.states["FOLLOW"] / total > 0.6, dict(result.states)
