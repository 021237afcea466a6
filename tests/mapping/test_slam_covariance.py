"""The covariances GraphSlam gives its edges, checked against sampled errors: the point-to-line refinement's (its
normal equations over its residuals' variance: chi-square about 3 at the truth), a weighted mean's, a loop-closure
submap's layout (its members placed by the links between them), an edge's information (the measured node's frame)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from amr_mapping import slam as slam_module
from amr_util.geometry import compose, relative_pose, wrap_angle


def _box(step: float) -> np.ndarray:
    """Points every `step` m along the walls of a 4 x 3 m room around the origin, and a pillar's two faces."""
    xs, ys = np.arange(-2.0, 2.0, step), np.arange(-1.5, 1.5, step)
    walls = [
        np.column_stack([xs, np.full_like(xs, -1.5)]),
        np.column_stack([xs, np.full_like(xs, 1.5)]),
        np.column_stack([np.full_like(ys, -2.0), ys]),
        np.column_stack([np.full_like(ys, 2.0), ys]),
    ]
    return np.vstack(walls)


def _reference(points: np.ndarray, resolution: float) -> slam_module._Reference:
    means = slam_module._voxel_means(points, slam_module.ALIGN_VOXEL_CELLS * resolution)
    centres, normals = slam_module._lines(means, points, slam_module.ALIGN_NEIGHBOURHOOD_CELLS * resolution)
    return slam_module._Reference(None, means, centres, normals, cKDTree(means))


def test_the_refinements_covariance_is_its_error():
    """A room's walls, scanned from a known pose with 1 cm of range noise and refined from 2 cm / 1 deg off: the
    refinement's error against its own information scores a chi-square of about 3 (3 dof) on average over 40 scans;
    at the 5 % share the weights use it scored about 0.15."""
    rng = np.random.default_rng(3)
    resolution = 0.05
    reference = _reference(_box(0.01) + rng.normal(0.0, 0.002, (len(_box(0.01)), 2)), resolution)
    truth = np.array([0.1, -0.05, 0.03])
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    chi2 = []
    for _ in range(40):
        # each beam's range to the room's walls from the true pose, with noise
        heading = truth[2] + angles
        c, s = np.cos(heading), np.sin(heading)
        with np.errstate(divide="ignore"):
            tx = np.where(c > 0, (2.0 - truth[0]) / c, (-2.0 - truth[0]) / c)
            ty = np.where(s > 0, (1.5 - truth[1]) / s, (-1.5 - truth[1]) / s)
        ranges = np.minimum(np.abs(tx), np.abs(ty)) + rng.normal(0.0, 0.01, len(angles))
        points = np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])
        start = truth + np.array([0.02, -0.015, math.radians(1.0)])
        pose, information = slam_module._align(reference, points, start, resolution)
        error = pose - truth
        error[2] = wrap_angle(error[2])
        chi2.append(float(error @ information @ error))
    assert 1.5 < np.mean(chi2) < 6.0, np.mean(chi2)


def test_a_weighted_means_covariance():
    """Two independent estimates weighed by their own informations: the mean's covariance is the informations'
    sum's inverse; weighed otherwise it is what sampling says (and more than that inverse)."""
    rng = np.random.default_rng(0)
    a, b = np.diag([1e-4, 4e-4, 1e-5]), np.diag([9e-4, 1e-4, 4e-5])
    exact = slam_module._fused_covariance((np.linalg.inv(a), a), (np.linalg.inv(b), b))
    assert np.allclose(exact, np.linalg.inv(np.linalg.inv(a) + np.linalg.inv(b)))
    weights = (0.05 * np.linalg.inv(a), np.linalg.inv(b))
    covariance = slam_module._fused_covariance((weights[0], a), (weights[1], b))
    samples_a = rng.multivariate_normal(np.zeros(3), a, 20_000)
    samples_b = rng.multivariate_normal(np.zeros(3), b, 20_000)
    mean = np.linalg.solve(weights[0] + weights[1], (weights[0] @ samples_a.T + weights[1] @ samples_b.T)).T
    sampled = np.cov(mean.T)
    assert np.allclose(np.diag(sampled), np.diag(covariance), rtol=0.05)
    scale = np.sqrt(np.outer(np.diag(covariance), np.diag(covariance)))
    assert np.all(np.abs(sampled - covariance) < 0.05 * scale)
    assert np.all(np.diag(covariance) > np.diag(exact))


def test_a_submaps_layout_covariance_is_its_members_motions_averaged():
    """Ten nodes along a bend, the anchor the sixth, each link off by its covariance: each member's rigid motion at the
    anchor's origin (as a scan matched to that member's points would move), sampled 4,000 times, has covariances
    whose mean over the members is what _layout_covariance gives (within 10 %); the anchor alone would not move."""
    rng = np.random.default_rng(1)
    steps = [(0.2, 0.0, 0.15)] * 9
    poses = [np.zeros(3)]
    for step in steps:
        poses.append(np.array(compose(poses[-1], step)))
    poses = np.array(poses)
    links = np.array([np.diag([0.003**2, 0.002**2, math.radians(0.3) ** 2])] * 9)
    anchor = 5
    layout = slam_module._layout_covariance(poses, links, anchor)
    relative = np.array([relative_pose(poses[anchor], p) for p in poses])
    motions = []
    for _ in range(4000):
        noisy = [poses[0]]
        for step, covariance in zip(steps, links, strict=True):
            noisy.append(np.array(compose(compose(noisy[-1], step), rng.multivariate_normal(np.zeros(3), covariance))))
        moved = np.array([relative_pose(noisy[anchor], p) for p in noisy])
        turn = wrap_angle(moved[:, 2] - relative[:, 2])
        shift = moved[:, :2] - relative[:, :2]
        # each member's motion at the anchor's origin: p -> p + u + w (-p_y, p_x), fitted at the member's origin
        u = shift - turn[:, None] * np.column_stack([-relative[:, 1], relative[:, 0]])
        motions.append(np.column_stack([u, turn]))
    motions = np.array(motions)  # (samples, members, 3)
    sampled = np.mean([np.cov(motions[:, m].T) for m in range(len(poses))], axis=0)
    assert np.allclose(np.diag(sampled), np.diag(layout), rtol=0.1), (np.diag(sampled), np.diag(layout))
    assert abs(sampled[0, 2] - layout[0, 2]) < 0.1 * math.sqrt(layout[0, 0] * layout[2, 2])
    assert np.allclose(np.cov(motions[:, anchor].T), 0.0, atol=1e-12)


def test_an_edges_information_is_its_covariance_in_the_measured_nodes_frame():
    """A covariance long along the anchor's x, the node turned 90 deg: the edge's (the node's frame) is long along
    its y; the standard deviations at least MIN_EDGE_SIGMA; a covariance that is not finite gives a weak edge."""
    covariance = np.diag([0.01**2, 0.001**2, 1e-6])
    rotated = slam_module._rotated(covariance, math.pi / 2)
    assert np.allclose(np.diag(rotated), [0.001**2, 0.01**2, 1e-6])
    information = slam_module._information(np.zeros((3, 3)))
    assert np.allclose(
        np.diag(information),
        1.0 / np.square([slam_module.MIN_EDGE_SIGMA[0], slam_module.MIN_EDGE_SIGMA[0], slam_module.MIN_EDGE_SIGMA[1]]),
    )
    assert np.all(np.diag(slam_module._information(np.full((3, 3), np.nan))) <= 1e-4)


def test_a_closures_covariance_is_its_refinements_at_the_closure_share_and_the_submaps_layout():
    """A closure's covariance: the refinement's normal equations at CLOSURE_INFORMATION_SHARE of their information
    (they see the scan's noise, not the submap's faults) plus the submap's layout carried to where the match put the
    node (a heading error of the layout moves a node 2 m off its anchor sideways)."""
    slam = slam_module.GraphSlam(slam_module.SlamConfig())
    aligned = np.diag([1.0 / 0.004**2, 1.0 / 0.003**2, 1.0 / math.radians(0.2) ** 2])
    layout = np.diag([0.0, 0.0, math.radians(0.5) ** 2])
    submap = slam_module._Submap(anchor=5, last=9, layout=layout)
    matched = np.array([2.0, 0.0, 0.1])
    covariance = slam._closure_covariance(submap, np.zeros((0, 2)), matched, aligned)
    own = np.linalg.inv(aligned) / slam_module.CLOSURE_INFORMATION_SHARE
    assert 0.0 < slam_module.CLOSURE_INFORMATION_SHARE < 1.0
    assert np.allclose(covariance[2, 2], own[2, 2] + layout[2, 2])
    assert np.isclose(covariance[0, 0], own[0, 0])
    assert np.isclose(covariance[1, 1], own[1, 1] + 4.0 * layout[2, 2])  # 2 m of lever


def test_a_match_keeps_no_information_along_a_wall_that_is_all_its_scan_sees():
    """One straight wall (a window's points on it ending where its scans stopped seeing, as in an open room with
    a 3.5 m LiDAR): the match's curvature along the wall is taken out and left to the odometry, the other directions
    kept; the same scan with a wall across its end (a corner) keeps every direction."""
    rng = np.random.default_rng(5)
    resolution = 0.05
    wall = np.column_stack([np.arange(-1.5, 1.5, 0.01), np.full(300, 1.0)]) + rng.normal(0.0, 0.002, (300, 2))
    scan = np.column_stack([np.linspace(-1.2, 1.8, 120), np.full(120, 1.0)])
    claimed = np.diag([2500.0, 4000.0, 900.0])  # 2 cm along, 1.6 cm across, 1.9 deg
    constrained = slam_module._constrained(claimed, _reference(wall, resolution), scan, np.zeros(3), resolution)
    assert 1.0 / math.sqrt(constrained[0, 0]) > 1.0  # along the wall: the odometry decides (MIN_MATCH_INFORMATION)
    assert constrained[1, 1] == pytest.approx(4000.0, rel=0.05) and constrained[2, 2] == pytest.approx(900.0, rel=0.05)
    end = np.column_stack([np.full(100, 1.5), np.linspace(0.0, 1.0, 100)])
    corner = _reference(np.vstack([wall, end]), resolution)
    seen = np.vstack([scan, np.column_stack([np.full(40, 1.5), np.linspace(0.2, 0.95, 40)])])
    np.testing.assert_allclose(slam_module._constrained(claimed, corner, seen, np.zeros(3), resolution), claimed)
