"""The particle filter's parts, each against its equation or a case solved by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_localization.beam_model import BeamModel, BeamModelParams
from amr_localization.clustering import cluster_particles
from amr_localization.distance_field import DistanceField
from amr_localization.errors import LocalizationError
from amr_localization.hypotheses import MERGE_ANGLE, MERGE_DISTANCE, PlaceHypotheses
from amr_localization.kld_sampling import kld_sample_count
from amr_localization.likelihood_field import LikelihoodField, LikelihoodFieldParams
from amr_localization.motion_model import (
    OdometryNoise,
    motion_covariance,
    motion_variance,
    sample_motion_model_odometry,
)
from amr_localization.pose_estimate import grouped_covariances, weighted_pose
from amr_localization.progressive_correction import BISECTION_STEPS, stage_exponent
from amr_localization.resampling import effective_sample_size, jitter, systematic_resample
from amr_localization.scan_beams import select_beams
from amr_localization.sensor_mount import SensorMount
from amr_maps.occupancy_grid import OCCUPIED, OccupancyGrid
from amr_maps.rasterize import rasterize_world as grid_of
from amr_maps.world import world_from_dict
from amr_simulation.config import LidarConfig, SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.geometry import compose, odometry_turns, off_line, relative_pose, wrap_angle
from amr_util.scan import ScanData, scan_of

ROOM = {  # 2 x 1.6 m room with a box off-centre: no symmetry
    "wall_thickness": 0.04,
    "walls": [[-1.0, -0.8, 1.0, -0.8], [1.0, -0.8, 1.0, 0.8], [1.0, 0.8, -1.0, 0.8], [-1.0, 0.8, -1.0, -0.8]],
    "boxes": [[0.3, 0.2, 0.6, 0.5]],
    "start": [-0.4, -0.3, 0.7],
}


def test_motion_without_noise_is_the_odometry_increment_applied_to_each_particle():
    rng = np.random.default_rng(0)
    particles = np.column_stack([rng.uniform(-1, 1, 50), rng.uniform(-1, 1, 50), rng.uniform(-math.pi, math.pi, 50)])
    before, after = (0.3, -0.2, 0.4), (0.42, -0.11, 0.9)
    moved = sample_motion_model_odometry(particles, before, after, OdometryNoise(0, 0, 0, 0), rng)
    expected = compose(particles, relative_pose(before, after))
    np.testing.assert_allclose(moved, expected, atol=1e-12)


def test_motion_noise_grows_with_alpha_and_is_reproducible():
    particles = np.zeros((4000, 3))
    spreads = []
    for alpha in (0.01, 0.1):
        noise = OdometryNoise(alpha, alpha, alpha, alpha)
        first = sample_motion_model_odometry(particles, (0, 0, 0), (0.1, 0.0, 0.1), noise, np.random.default_rng(3))
        again = sample_motion_model_odometry(particles, (0, 0, 0), (0.1, 0.0, 0.1), noise, np.random.default_rng(3))
        np.testing.assert_array_equal(first, again)
        spreads.append(first[:, 0].std())
    assert spreads[1] > 2.5 * spreads[0]
    with pytest.raises(LocalizationError, match="alpha3"):
        OdometryNoise(0.1, 0.1, -1.0, 0.1)


@pytest.mark.parametrize(
    "increment",
    [(3.0, 0.1, 0.05), (0.003, 0.05, 0.55), (-0.8, 0.1, -0.3), (1.0, 0.6, 0.9)],
    ids=["a 3 m keyframe", "a turn in place that slid 5 cm sideways", "backwards", "an arc"],
)
def test_the_motion_covariance_is_the_spread_the_sampler_gives_the_particles(increment):
    """motion_covariance (what the scan-matched odometry's prior is) and motion_variance's heading (the places' and
    the search's) against 40,000 particles moved from one pose: a turn in place whose odometry slid sideways is a
    quarter turn off the line each way for the sampler, its heading's noise several times the net turn's."""
    noise = OdometryNoise(0.01, 0.01, 0.01, 0.01)
    moved = sample_motion_model_odometry(np.zeros((40000, 3)), (0, 0, 0), increment, noise, np.random.default_rng(5))
    offsets = moved - increment
    offsets[:, 2] = wrap_angle(offsets[:, 2])
    sampled = np.cov(offsets.T)
    covariance = motion_covariance(increment, noise)
    sigmas = np.sqrt(np.diag(sampled))
    # first order: the heading's and the wider position axis's standard deviations within 10 %, their correlation
    # within 0.1; the narrower axis is second order's (a 3 m step's rot1 noise of 0.3 rad shortens it by t e^2 / 2)
    modelled = np.sqrt(np.diag(covariance))
    wide = int(np.argmax(sigmas[:2]))
    np.testing.assert_allclose(modelled[[wide, 2]], sigmas[[wide, 2]], rtol=0.1)
    assert covariance[wide, 2] / (modelled[wide] * modelled[2]) == pytest.approx(
        sampled[wide, 2] / (sigmas[wide] * sigmas[2]), abs=0.1
    )
    rot1, trans, rot2 = odometry_turns((0.0, 0.0, 0.0), increment)
    along = math.sqrt(noise.alpha3 * trans**2 + noise.alpha4 * (off_line(rot1) ** 2 + off_line(rot2) ** 2))
    assert 0.99 * along <= modelled[1 - wide] <= 1.1 * max(sigmas[1 - wide], along), "floored at the travel's noise"
    assert motion_variance(increment, noise)[1] == pytest.approx(covariance[2, 2])
    if increment[1] == 0.05:
        assert math.sqrt(covariance[2, 2]) > 3.0 * 0.1 * increment[2], "not 10 % of the net turn"


def test_a_turn_exactly_on_the_spot_may_slip_sideways_as_much_as_along():
    """At first order the sampler moves a turn on the spot only along the heading (its translation's noise); the
    covariance floors the other direction there, so that a scan match may find a slip."""
    noise = OdometryNoise(0.01, 0.02, 0.03, 0.04)
    covariance = motion_covariance((0.0, 0.0, 1.0), noise)
    np.testing.assert_allclose(covariance[:2, :2], 0.04 * np.eye(2), atol=1e-15)
    assert covariance[2, 2] == pytest.approx(0.01)


def test_likelihood_field_scores_the_true_pose_above_poses_a_few_cm_or_degrees_off():
    world = world_from_dict(ROOM)
    sim = Simulator(world, SimulationConfig(lidar=LidarConfig(noise_std=0.01)))
    field = DistanceField(grid_of(world, 0.02))
    model = LikelihoodField(field, LikelihoodFieldParams(), SensorMount(x=-0.032), 3.5)
    beams = select_beams(scan_of(sim), 60)
    truth = np.array(sim.pose)
    offsets = np.array([[0, 0, 0], [0.05, 0, 0], [0, -0.05, 0], [0, 0, math.radians(5)], [0.1, 0.1, 0.2]])
    scores = model.log_likelihood(truth + offsets, beams)
    assert scores.argmax() == 0
    # the beam model (ray casting) ranks them the same way
    beam_scores = BeamModel(field, BeamModelParams(), SensorMount(x=-0.032)).log_likelihood(truth + offsets, beams)
    assert beam_scores.argmax() == 0


def test_missing_returns_and_invalid_readings_are_skipped_not_read_as_zero():
    ranges = np.array([1.0, np.nan, np.inf, -np.inf, 0.0, 5.0, 2.0])
    scan = ScanData(ranges, 0.0, 0.1, 0.12, 3.5)
    beams = select_beams(scan, 60)
    np.testing.assert_array_equal(beams.ranges, [1.0, 2.0])
    np.testing.assert_allclose(beams.angles, [0.0, 0.6])
    with_no_return = select_beams(scan, 60, keep_no_return=True)
    np.testing.assert_array_equal(with_no_return.returned, [True, False, True])
    assert select_beams(ScanData(np.arange(1.0, 241.0) / 100, 0.0, 0.026, 0.0, 3.5), 30).ranges.size == 30
    for bad, message in [
        (ScanData([], 0.0, 0.1, 0.1, 3.5), "non-empty"),
        (ScanData([1.0, 1.0], math.nan, 0.1, 0.1, 3.5), "angle_min"),
        (ScanData([1.0], 0.0, 0.1, 2.0, 1.0), "range_min"),
        (ScanData(["a"], 0.0, 0.1, 0.1, 3.5), "not numbers"),
    ]:
        with pytest.raises(LocalizationError, match=message):
            select_beams(bad, 60)


def test_systematic_resampling_gives_each_particle_floor_or_ceil_of_its_share():
    weights = np.array([0.5, 0.25, 0.125, 0.125])
    counts = np.bincount(systematic_resample(weights, 1000, np.random.default_rng(1)), minlength=4)
    assert np.all(np.abs(counts - 1000 * weights) <= 1)
    assert effective_sample_size(np.full(10, 0.1)) == pytest.approx(10)
    assert effective_sample_size(np.array([1.0, 0.0])) == pytest.approx(1)


def test_kld_count_grows_with_occupied_bins():
    counts = [kld_sample_count(k, 0.05, 0.01) for k in (1, 2, 10, 100, 1000)]
    assert counts == sorted(counts) and counts[0] == 1 and counts[-1] > 10000 > counts[2]


def test_clusters_separate_distant_groups_rank_them_by_weight_and_ignore_sparse_noise():
    rng = np.random.default_rng(2)
    a = rng.normal([0, 0], 0.03, (300, 2))
    b = rng.normal([2, 1], 0.03, (300, 2))
    noise = rng.uniform(-3, 3, (20, 2))
    xy = np.vstack([a, b, noise])
    weights = np.concatenate([np.full(300, 1.0), np.full(300, 2.0), np.full(20, 1.0)])
    clusters = cluster_particles(xy, weights / weights.sum(), 0.1, 10)
    assert clusters.count == 2
    assert np.all(clusters.labels[300:600] == 0) and np.all(clusters.labels[:300] == 1)
    assert clusters.weights[0] == pytest.approx(600 / 920, rel=0.05)


def test_clusters_join_touching_dense_cells_across_the_heading_wrap_however_far_the_cloud_spreads():
    """Dense cells touching (26-neighbourhood, the heading's last bin beside its first) are one cluster, as a
    flood fill over every cell of the cloud's bounding box would find; a cloud spread over 100 m beside a tight one
    (a global start's particles) costs the dense cells' look-ups, not the box's tens of millions of cells."""
    rng = np.random.default_rng(3)
    across = np.column_stack([rng.normal([50.0, 50.0], 0.03, (200, 2)), rng.normal(math.pi, 0.05, 200)])
    apart = np.column_stack([rng.normal([50.6, 50.0], 0.03, (200, 2)), rng.normal(math.pi, 0.05, 200)])
    spread = np.column_stack([rng.uniform(0.0, 100.0, (4000, 2)), rng.uniform(-math.pi, math.pi, 4000)])
    particles = np.vstack([across, apart, spread])
    clusters = cluster_particles(particles[:, :2], np.full(len(particles), 1.0), 0.1, 10, particles[:, 2])
    assert clusters.count == 2
    # the headings on either side of +-pi (bins 23 and 0) are one cluster, the one 0.6 m away another
    assert len(np.unique(clusters.labels[:200])) == 1 and clusters.labels[0] >= 0
    assert len(np.unique(clusters.labels[200:400])) == 1 and clusters.labels[200] != clusters.labels[0]
    assert (clusters.labels[400:] == -1).all()  # one particle per 2.5 m^2: noise
    assert sorted(clusters.sizes) == [200, 200]


def test_estimate_heading_is_the_circular_mean_across_pi():
    particles = np.array([[0.0, 0.0, math.pi - 0.1], [1.0, 2.0, -math.pi + 0.1]])
    estimate = weighted_pose(particles, np.array([1.0, 1.0]))
    assert abs(abs(estimate.theta) - math.pi) < 1e-9
    assert (estimate.x, estimate.y) == pytest.approx((0.5, 1.0))
    assert estimate.heading_std == pytest.approx(0.1)


def test_a_map_without_free_space_or_occupied_cells_is_refused_by_name():
    from amr_localization.free_space import FreeSpace

    solid = OccupancyGrid(np.full((20, 20), OCCUPIED, dtype=np.int8), 0.05)
    with pytest.raises(LocalizationError, match="no free cell"):
        FreeSpace(DistanceField(solid), 0.08)
    empty = OccupancyGrid(np.zeros((20, 20), dtype=np.int8), 0.05)
    with pytest.raises(LocalizationError, match="at least one occupied cell"):
        BeamModel(DistanceField(empty), BeamModelParams(), SensorMount())
    with pytest.raises(LocalizationError, match="OccupancyGrid"):
        DistanceField(np.zeros((3, 3)))


def test_the_compiled_likelihood_sum_equals_the_formula_beam_by_beam():
    """The kernel against the module docstring's formula in plain numpy: end point, nearest wall, log p."""
    from scipy.ndimage import distance_transform_edt

    data = np.zeros((40, 50), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    data[10:30, 20] = OCCUPIED
    grid = OccupancyGrid(data, 0.05, (-1.0, -0.5, 0.0))
    params = LikelihoodFieldParams(sigma_hit=0.05, z_hit=0.9, z_rand=0.1, max_dist=0.5)
    mount = SensorMount(x=-0.032)
    model = LikelihoodField(DistanceField(grid), params, mount, 3.5)
    rng = np.random.default_rng(3)
    particles = np.column_stack([rng.uniform(-0.9, 1.4, 200), rng.uniform(-0.4, 1.4, 200), rng.uniform(-4, 4, 200)])
    ranges = np.append(rng.uniform(0.1, 3.0, 23), np.inf)  # the last beam has no return: skipped
    angles = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)
    from amr_localization.scan_beams import Beams

    beams = Beams(ranges, angles, np.isfinite(ranges), 3.5, np.arange(24), angles[1])
    sensor = mount.sensor_poses(particles)
    ends_x = sensor[:, :1] + ranges[None, :23] * np.cos(sensor[:, 2:] + angles[None, :23])
    ends_y = sensor[:, 1:2] + ranges[None, :23] * np.sin(sensor[:, 2:] + angles[None, :23])
    distance = np.minimum(np.pad(distance_transform_edt(data < 65) * 0.05, 1, constant_values=np.inf), 0.5)
    col = np.clip(np.floor((ends_x + 1.0) / 0.05) + 1, 0, distance.shape[1] - 1).astype(int)
    row = np.clip(np.floor((ends_y + 0.5) / 0.05) + 1, 0, distance.shape[0] - 1).astype(int)
    d = distance[row, col]
    expected = np.log(0.9 * np.exp(-0.5 * (d / 0.05) ** 2) / (0.05 * math.sqrt(2 * math.pi)) + 0.1 / 3.5).sum(axis=1)
    assert model.log_likelihood(particles, beams) == pytest.approx(expected, rel=1e-5, abs=1e-3)


def test_thousands_of_particles_score_as_each_would_among_a_few():
    """From SPLIT_PARTICLES on, the likelihood's sums run in two halves side by side: each particle's value is the one
    it gets scored among a hundred, to the bit."""
    from amr_localization.likelihood_field import SPLIT_PARTICLES
    from amr_localization.scan_beams import Beams

    data = np.zeros((40, 50), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    data[10:30, 20] = OCCUPIED
    model = LikelihoodField(
        DistanceField(OccupancyGrid(data, 0.05, (-1.0, -0.5, 0.0))), LikelihoodFieldParams(), SensorMount(x=-0.032), 3.5
    )
    rng = np.random.default_rng(4)
    count = SPLIT_PARTICLES + 301
    particles = np.column_stack(
        [rng.uniform(-0.9, 1.4, count), rng.uniform(-0.4, 1.4, count), rng.uniform(-4, 4, count)]
    )
    ranges = rng.uniform(0.1, 3.0, 24)
    angles = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)
    beams = Beams(ranges, angles, np.ones(24, dtype=bool), 3.5, np.arange(24), angles[1])
    weights = rng.uniform(0.2, 1.0, 24)
    together = model.log_likelihood(particles, beams, weights)
    alone = [model.log_likelihood(particles[i : i + 100], beams, weights) for i in range(0, count, 100)]
    np.testing.assert_array_equal(together, np.concatenate(alone))


def _share(log_weights: np.ndarray) -> float:
    weights = np.exp(log_weights - log_weights.max())
    return weights.sum() ** 2 / (weights @ weights) / len(weights)


def test_the_stage_exponent_is_the_largest_that_keeps_the_effective_sample_size():
    """Progressive correction's step: the largest lambda (to the bisection's resolution) whose weights keep N_eff at
    the target share of the particles, dead particles (prior -inf) left out; the whole rest where that keeps it."""
    rng = np.random.default_rng(5)
    log_prior = np.log(rng.uniform(0.5, 1.0, 3000))
    log_prior[:500] = -np.inf
    log_likelihood = rng.normal(0.0, 40.0, 3000)
    step = stage_exponent(log_prior, log_likelihood, 1.0, 0.5)
    alive = np.isfinite(log_prior)
    target = 0.5 * 3000 / alive.sum()
    assert 0.0 < step < 1.0
    assert _share(log_prior[alive] + step * log_likelihood[alive]) >= target
    assert _share(log_prior[alive] + (step + 2.0**-BISECTION_STEPS) * log_likelihood[alive]) < target
    flat = rng.normal(0.0, 0.01, 3000)
    assert stage_exponent(log_prior, flat, 0.7, 0.5) == 0.7


def test_a_pose_is_found_at_the_nearest_place_within_the_merge_window_across_the_angle_wrap():
    rng = np.random.default_rng(6)
    places = PlaceHypotheses()
    places.add(np.array([[0.0, 0.0, math.pi - 0.01], [0.1, 0.0, -math.pi + 0.01], [3.0, 3.0, 0.0]]), np.zeros(3))
    poses = np.column_stack(
        [rng.uniform(-0.5, 3.5, 4000), rng.uniform(-0.5, 3.5, 4000), rng.uniform(-math.pi, math.pi, 4000)]
    )
    poses[:2000, :2] = rng.normal(0.0, MERGE_DISTANCE, (2000, 2))
    poses[:2000, 2] = math.pi + rng.normal(0.0, MERGE_ANGLE, 2000)
    near = np.hypot(poses[:, None, 0] - places.poses[None, :, 0], poses[:, None, 1] - places.poses[None, :, 1])
    turn = np.abs(np.mod(poses[:, None, 2] - places.poses[None, :, 2] + math.pi, 2.0 * math.pi) - math.pi)
    distance = np.where(turn <= MERGE_ANGLE, near, np.inf)
    expected = np.where(distance.min(axis=1) <= MERGE_DISTANCE, distance.argmin(axis=1), -1)
    found = places.find(poses)
    assert {0, 1, -1} <= set(found.tolist()), "both places across the wrap, and none"
    np.testing.assert_array_equal(found, expected)


def test_a_place_keeps_its_identity_however_far_it_is_moved_ranked_or_merged():
    """The place declared is a place, not a pose: its identity follows it through a re-anchoring further than the
    merge window (a keyframe's odometry error taken out by the scan's fit), a change of rank, and a merge into a
    stronger place (then it is that place); a place forgotten has none."""
    places = PlaceHypotheses()
    places.add(np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [9.0, 0.0, 0.0]]), np.array([0.0, -2.0, -4.0]))
    first, second, third = (int(i) for i in places.ids)
    assert len({first, second, third}) == 3
    places.reanchor(0, np.array([0.6, -0.4, 0.1]))  # 0.72 m: beyond MERGE_DISTANCE, the same place
    assert places.index_of(first) == 0
    places.observe(np.array([0.0, 3.0, 0.0]), -10.0)  # the second overtakes the first
    assert places.index_of(second) == 0 and places.index_of(first) == 1
    places.reanchor(2, places.poses[0] + (0.1, 0.0, 0.0))  # the third comes onto the (stronger) second: merged
    places.merge()
    assert len(places) == 2 and places.index_of(third) == places.index_of(second) == 0
    places.keep(np.array([True, False]))  # the first in a wall: forgotten
    assert places.index_of(first) == -1 and places.index_of(None) == -1
    places.add(np.array([[0.0, 0.0, 0.0]]), np.zeros(1))  # born where the first was: a new place
    assert places.index_of(first) == -1 and int(places.ids[-1]) not in (first, second, third)


def test_the_kernel_moves_each_place_s_poses_by_its_factor_in_free_space_only():
    """jitter takes the draws place by place, each place's poses in their order: the same moves as drawing for each
    place in turn and applying its factor; a move out of the free cells leaves the pose where it was."""
    rng = np.random.default_rng(7)
    poses = np.column_stack([rng.uniform(0.0, 4.0, 300), rng.uniform(0.0, 3.0, 300), rng.uniform(-3.1, 3.1, 300)])
    owner = rng.integers(-1, 3, 300)
    free = rng.random((30, 40)) < 0.8  # cells of 0.1 m from (0, 0): rows y, columns x
    places = np.array([0, 2])
    factors = np.array([np.linalg.cholesky(m @ m.T + 0.01 * np.eye(3)) for m in rng.normal(0.0, 0.3, (2, 3, 3))])
    draws = rng.standard_normal((int(np.isin(owner, places).sum()), 3))
    expected, used = poses.copy(), 0
    for factor, place in zip(factors, places, strict=True):
        rows = np.flatnonzero(owner == place)
        moved = poses[rows] + 0.4 * draws[used : used + len(rows)] @ factor.T
        used += len(rows)
        col, row = np.floor(moved[:, 0] / 0.1).astype(int), np.floor(moved[:, 1] / 0.1).astype(int)
        inside = (row >= 0) & (row < 30) & (col >= 0) & (col < 40)
        inside[inside] = free[row[inside], col[inside]]
        moved[:, 2] = np.mod(moved[:, 2] + math.pi, 2.0 * math.pi) - math.pi
        expected[rows[inside]] = moved[inside]
    got = poses.copy()
    jitter(got, owner, places, factors, draws, 0.4, free, 0.0, 0.0, 0.1)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    moved = (got != poses).any(axis=1)
    assert moved[owner == 0].any() and not moved[owner == 1].any() and (~moved[owner == 2]).any()


def test_each_group_s_covariance_is_its_particles_weighted_pose_covariance():
    rng = np.random.default_rng(8)
    particles = np.column_stack([rng.normal(0, 1, 2000), rng.normal(0, 1, 2000), rng.uniform(-3.2, 3.2, 2000)])
    weights, owner = rng.random(2000), rng.integers(-1, 4, 2000)
    weights[owner == 2] = 0.0  # a group of dead particles: equal weights, as weighted_pose takes them
    covariances, counts = grouped_covariances(particles, weights, owner, 4)
    for group in range(4):
        member = owner == group
        assert counts[group] == member.sum()
        expected = weighted_pose(particles[member], weights[member]).covariance
        np.testing.assert_allclose(covariances[group], expected, atol=1e-12)


def test_clusters_are_the_8_connected_components_of_the_dense_cells():
    """Against scipy's labelling of the whole box (2-D): the same partition of the particles into clusters."""
    from scipy import ndimage

    rng = np.random.default_rng(9)
    for _ in range(20):
        xy = rng.uniform(0.0, 3.0, (1500, 2))
        clusters = cluster_particles(xy, np.ones(1500), 0.1, 3)
        cells = np.floor(xy / 0.1).astype(int)
        counts = np.zeros((31, 31), dtype=int)
        np.add.at(counts, (cells[:, 0], cells[:, 1]), 1)
        labels, _ = ndimage.label(counts >= 3, structure=np.ones((3, 3)))
        expected = labels[cells[:, 0], cells[:, 1]] - 1
        assert (clusters.labels >= 0).sum() > 500 and clusters.count > 1
        pairs = set(zip(clusters.labels.tolist(), expected.tolist(), strict=True))
        assert len(pairs) == len({a for a, _ in pairs}) == len({b for _, b in pairs}), "one cluster, one component"
        assert ((clusters.labels < 0) == (expected < 0)).all()
