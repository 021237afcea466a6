"""Seed 000's beacon localizer, and beacon ranges as a particle filter measurement."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.localization import WORLDS_DIR

from amr_localization.beacon_localizer import BeaconLocalizer, BeaconLocalizerConfig
from amr_localization.beacons import BeaconReading, expected_ranges, same_beacons
from amr_localization.errors import LocalizationError
from amr_localization.particle_filter import ParticleFilter
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_maps.rasterize import rasterize_world as grid_of
from amr_maps.world import load_world

BEACONS = np.array([[0.0, 0.0], [4.0, 0.5], [3.5, 4.0], [0.5, 3.5]])


def reading(x, y, theta, rng, noise=0.01):
    ranges = expected_ranges(np.array([[x, y]]), BEACONS)[0] + rng.normal(0.0, noise, len(BEACONS))
    return ranges, theta + rng.normal(0.0, noise)


@pytest.mark.parametrize("seed", range(5))
def test_pyramidal_relocalization_is_within_2_cm_with_far_fewer_evaluations_than_the_exhaustive_grid(seed):
    rng = np.random.default_rng(seed)
    truth = (rng.uniform(0.5, 3.5), rng.uniform(0.5, 3.5), rng.uniform(-math.pi, math.pi))
    guess = (truth[0] + rng.uniform(-1.5, 1.5), truth[1] + rng.uniform(-1.5, 1.5), 0.0)
    ranges, compass = reading(*truth, rng, noise=0.005)
    localizer = BeaconLocalizer(BEACONS, BeaconLocalizerConfig(resolution=0.005), initial_pose=guess)
    update = localizer.update((0.0, 0.0, 0.0), ranges, compass)
    assert update.relocalized
    assert math.hypot(update.pose[0] - truth[0], update.pose[1] - truth[1]) <= 0.02
    assert abs(update.pose[2] - compass) < 1e-12  # the orientation comes from the compass
    exhaustive = BeaconLocalizer(BEACONS, BeaconLocalizerConfig(resolution=0.02), initial_pose=guess)
    full = exhaustive.relocalize(BeaconReading.checked(ranges, compass, 4), pyramidal=False)
    coarse = BeaconLocalizer(BEACONS, BeaconLocalizerConfig(resolution=0.02), initial_pose=guess)
    pyramid = coarse.relocalize(BeaconReading.checked(ranges, compass, 4))
    assert np.allclose(full.position, pyramid.position, atol=0.02 + 1e-9)
    assert pyramid.evaluations * 50 < full.evaluations


def test_the_search_square_covers_the_beacons_and_the_margin():
    localizer = BeaconLocalizer(BEACONS, BeaconLocalizerConfig(margin=0.5))
    assert localizer.search_radius((2.0, 2.0)) == pytest.approx(2.5)
    assert localizer.search_radius((6.0, 2.0)) == pytest.approx(6.5)


def test_odometry_tracks_until_the_mismatch_passes_the_threshold():
    rng = np.random.default_rng(1)
    localizer = BeaconLocalizer(BEACONS, BeaconLocalizerConfig(threshold=0.1), initial_pose=(1.0, 1.0, 0.0))
    first = localizer.update((0.0, 0.0, 0.0), *reading(1.0, 1.0, 0.0, rng, 0.001))
    assert not first.relocalized and first.mismatch < 0.1
    moved = localizer.update((0.5, 0.0, 0.0), *reading(1.5, 1.0, 0.0, rng, 0.001))
    assert not moved.relocalized and moved.pose[:2] == pytest.approx((1.5, 1.0))
    slipped = localizer.update((0.6, 0.0, 0.0), *reading(2.0, 1.3, 0.2, rng, 0.001))  # wheels lied
    assert slipped.relocalized and slipped.mismatch > 0.1
    assert math.hypot(slipped.pose[0] - 2.0, slipped.pose[1] - 1.3) < 0.02


def test_bad_beacon_input_is_refused_by_name():
    with pytest.raises(LocalizationError, match="empty"):
        BeaconLocalizer([])
    with pytest.raises(LocalizationError, match="finite"):
        BeaconLocalizer([[0.0, math.nan]])
    localizer = BeaconLocalizer(BEACONS)
    with pytest.raises(LocalizationError, match="expected 4 values"):
        localizer.update((0.0, 0.0, 0.0), [1.0, 2.0], 0.0)
    with pytest.raises(LocalizationError, match="finite number >= 0"):
        localizer.update((0.0, 0.0, 0.0), [1.0, 2.0, math.nan, 1.0], 0.0)
    with pytest.raises(LocalizationError, match="compass"):
        localizer.update((0.0, 0.0, 0.0), [1.0, 2.0, 1.0, 1.0], math.inf)


def test_the_particle_filter_localizes_from_beacon_ranges_alone():
    world = load_world(WORLDS_DIR / "open_room.yaml")
    beacons = np.array([[-1.9, -1.4], [1.9, -1.4], [0.0, 1.4]])
    pf = ParticleFilter(
        grid_of(world, 0.05),
        ParticleFilterConfig(max_particles=2000, beacon_sigma_range=0.03, beacon_sigma_compass=0.03),
        beacons=beacons,
    )
    rng = np.random.default_rng(4)
    x, y, theta = -1.5, -1.0, 0.2
    errors = []
    for _ in range(300):
        x, y, theta = (
            x + 0.005 * math.cos(theta),
            y + 0.005 * math.sin(theta),
            theta - 0.001,
        )  # driving forward, clear of the pillar
        z = np.hypot(beacons[:, 0] - x, beacons[:, 1] - y) + rng.normal(0, 0.01, 3)
        estimate = pf.update((x, y, theta), beacons=BeaconReading.checked(z, theta + rng.normal(0, 0.01), 3))
        errors.append(math.hypot(estimate.pose.x - x, estimate.pose.y - y))
    # from a uniform start to about a decimetre: three ranges inform far less than a scan (the beacon localizer's
    # grid search is the precise tool here)
    assert errors[0] > 2.0 * errors[-1] and errors[-1] < 0.15
    assert abs(estimate.pose.theta - theta) < 0.05


def test_a_beacons_only_filter_keeps_tracking_once_localized():
    """Localized without a scan, the place hypotheses have no scan window and no place search: beacon readings alone
    keep them and the particles on the robot."""
    world = load_world(WORLDS_DIR / "open_room.yaml")
    beacons = np.array(world.beacons)
    pf = ParticleFilter(grid_of(world, 0.05), ParticleFilterConfig(max_particles=2000), beacons=beacons)
    rng = np.random.default_rng(5)
    x, y, theta = -1.5, -1.0, 0.2
    localized_updates = 0
    for _ in range(600):
        x, y, theta = x + 0.005 * math.cos(theta), y + 0.005 * math.sin(theta), theta + 0.004
        z = np.hypot(beacons[:, 0] - x, beacons[:, 1] - y) + rng.normal(0, 0.01, len(beacons))
        estimate = pf.update((x, y, theta), beacons=BeaconReading.checked(z, theta + rng.normal(0, 0.01), len(beacons)))
        localized_updates += estimate.localized and estimate.status.updated
    assert localized_updates >= 20
    assert estimate.localized and math.hypot(estimate.pose.x - x, estimate.pose.y - y) < 0.05


def test_the_filter_takes_beacon_positions_once_and_refuses_other_ones():
    """A node learns the positions from the first reading (set_beacons); other positions or another count
    are refused by name, and a refused reading leaves the filter as it was."""
    world = load_world(WORLDS_DIR / "open_room.yaml")
    assert world.beacons == ((-1.9, -1.4), (1.9, -1.4), (1.9, 1.4), (-1.9, 1.4)), "the shipped beacon world"
    pf = ParticleFilter(grid_of(world, 0.05), ParticleFilterConfig(max_particles=300))
    pf.set_beacons(world.beacons)
    pf.set_beacons(np.array(world.beacons) + 1e-9)  # the same beacons: accepted
    moved = np.array(world.beacons)
    moved[1, 1] += 0.2
    with pytest.raises(LocalizationError, match=r"beacon 1 at \(1.900, -1.200\), expected \(1.900, -1.400\)"):
        pf.set_beacons(moved)
    with pytest.raises(LocalizationError, match="3 beacon positions, expected 4"):
        same_beacons(pf.beacons, world.beacons[:3])
    with pytest.raises(LocalizationError, match="finite"):
        same_beacons(pf.beacons, [[math.nan, 0.0]] * 4)
    with pytest.raises(LocalizationError, match="range 2 is nan"):
        BeaconReading.checked([1.0, 1.0, math.nan, 1.0], 0.0, 4)
    pf.update((0.0, 0.0, 0.0), beacons=BeaconReading.checked([1.0, 2.0, 3.0, 2.0], 0.0, 4))
    particles, weights = pf.particles.copy(), pf.weights.copy()
    with pytest.raises(LocalizationError, match="expected 4 values, got 3"):
        pf.update((0.1, 0.0, 0.0), beacons=BeaconReading(np.array([1.0, 2.0, 3.0]), 0.0))
    np.testing.assert_array_equal(pf.particles, particles)  # refused before the motion update
    np.testing.assert_array_equal(pf.weights, weights)
