"""What the viewer knows of a robot: frames, map image, scan through TF, particles, trail, estimate."""

import math

import numpy as np
import pytest

from amr_util.geometry import Pose2D, compose, transform_points
from amr_util.scan import ScanData
from amr_viewer.cdr import StampedTransform
from amr_viewer.frames import TransformTree
from amr_viewer.state import Estimate, RobotState, Scan, Trail, decimate, map_image

RNG = np.random.default_rng(3)


def tf(parent, child, x, y, yaw, stamp=0.0):
    return StampedTransform(parent, child, stamp, Pose2D(x, y, yaw))


def test_tree_lookups_compose_chains_and_invert():
    tree = TransformTree()
    a, b, c = Pose2D(1.0, 2.0, 0.5), Pose2D(-0.3, 0.4, -1.0), Pose2D(0.1, 0.0, 0.0)
    tree.set("map", "odom", a)
    tree.set("/odom", "base_footprint", b)
    tree.set("base_footprint", "base_scan", c)
    assert tree.lookup("map", "base_scan") == pytest.approx(compose(compose(a, b), c))
    back = tree.lookup("base_scan", "map")
    assert compose(tree.lookup("map", "base_scan"), back) == pytest.approx((0, 0, 0), abs=1e-12)
    assert tree.lookup("odom", "odom") == (0.0, 0.0, 0.0)
    tree.set("world", "other", Pose2D(0, 0, 0))
    assert tree.lookup("map", "other") is None, "two trees"
    assert not tree.set("map", "map", a) and not tree.set("map", "x", Pose2D(math.nan, 0, 0))


def test_without_a_localizer_odometry_is_drawn_as_the_map():
    state = RobotState("")
    state.on_transforms([tf("odom", "base_footprint", 1.0, 2.0, 0.3)])
    assert state.robot_pose() == pytest.approx((1.0, 2.0, 0.3))
    state.on_transforms([tf("map", "odom", 0.5, 0.0, 0.0)])
    assert state.robot_pose() == pytest.approx((1.5, 2.0, 0.3)), "a localizer's map -> odom counts once it comes"


def test_a_fleet_on_one_shared_tree_is_drawn_from_its_prefixed_frames():
    # the simulator's one_tf_tree: every robot's transforms on the one /tf, frames prefixed by its name
    shared = [
        tf("map", "r1/odom", 0.5, 0.0, 0.0),
        tf("r1/odom", "r1/base_footprint", 1.0, 2.0, 0.3),
        tf("map", "r2/odom", 0.0, 0.0, 0.0),
        tf("r2/odom", "r2/base_footprint", -1.0, -2.0, 1.0),
        tf("r1/base_footprint", "r1/base_scan", -0.032, 0.0, 0.0),
    ]
    r1, r2 = RobotState("/r1"), RobotState("r2")
    for state in (r1, r2):
        assert state.robot_pose() is None
        state.on_transforms(shared)
    assert r1.robot_pose() == pytest.approx((1.5, 2.0, 0.3))
    assert r2.robot_pose() == pytest.approx((-1.0, -2.0, 1.0))
    r1.on_scan(Scan(ScanData(np.array([1.0]), 0.0, 0.1, 0.1, 4.0), "r1/base_scan"))
    assert r1.scan_in_map() == pytest.approx(
        np.array([[1.5 - 0.032 * math.cos(0.3) + math.cos(0.3), 2.0 - 0.032 * math.sin(0.3) + math.sin(0.3)]])
    )
    # a namespaced robot whose own tree has the plain frames keeps them
    plain = RobotState("/r3")
    plain.on_transforms([tf("odom", "base_footprint", 3.0, 0.0, 0.0)])
    assert plain.robot_pose() == pytest.approx((3.0, 0.0, 0.0)) and plain.frames.base == "base_footprint"


def test_the_ground_truth_places_a_robot_without_tf():
    state = RobotState("")
    assert state.robot_pose() is None and state.extent() is None
    state.on_ground_truth(tf("map", "base_footprint", -1.0, 0.5, 1.0))
    assert state.robot_pose() == pytest.approx((-1.0, 0.5, 1.0))
    assert state.extent() == pytest.approx((-3.0, -1.5, 1.0, 2.5))


def test_map_image_rows_start_at_the_origin_and_cells_have_their_gray():
    data = np.zeros((3, 4), dtype=int)
    data[0, 0], data[2, 3], data[1, 1] = 100, -1, 50
    image = map_image(4, 3, 0.5, Pose2D(-1.0, 2.0, 0.0), data.ravel())
    assert image.rgb.shape == (3, 4, 3) and image.rgb.dtype == np.uint8
    assert image.rgb[0, 0, 0] < image.rgb[1, 1, 0] < image.rgb[0, 1, 0], "occupied dark, free light"
    assert image.rgb[2, 3, 0] == 200, "unknown mid-gray"
    assert (image.width, image.height) == (2.0, 1.5)
    assert image.center == pytest.approx((0.0, 2.75, 0.0))
    assert image.bounds == pytest.approx((-1.0, 2.0, 1.0, 3.5))
    turned = map_image(4, 3, 0.5, Pose2D(0.0, 0.0, math.pi / 2), data.ravel())
    assert turned.center == pytest.approx((-0.75, 1.0, math.pi / 2))
    assert turned.bounds == pytest.approx((-1.5, 0.0, 0.0, 2.0))
    with pytest.raises(ValueError, match="12 cells, 4 x 4 = 16 expected"):
        map_image(4, 4, 0.5, Pose2D(0, 0, 0), data.ravel())
    with pytest.raises(ValueError, match="not drawable"):
        map_image(4, 3, 0.0, Pose2D(0, 0, 0), data.ravel())


def test_the_scan_is_placed_through_tf_at_its_frame():
    state = RobotState("")
    base, mount = Pose2D(1.0, -1.0, math.pi / 2), Pose2D(-0.032, 0.0, 0.0)
    state.on_transforms([tf("odom", "base_footprint", *base)])
    state.on_transforms([tf("base_footprint", "base_scan", *mount)])
    ranges = RNG.uniform(0.2, 3.0, 36)
    ranges[5] = np.inf
    state.on_scan(Scan(ScanData(ranges, -math.pi, 2 * math.pi / 36, 0.12, 3.5), "base_scan"))
    points = state.scan_in_map()
    angles = -math.pi + 2 * math.pi / 36 * np.delete(np.arange(36), 5)
    local = np.column_stack([np.delete(ranges, 5) * np.cos(angles), np.delete(ranges, 5) * np.sin(angles)])
    assert points == pytest.approx(transform_points(compose(base, mount), local))
    unplaced = RobotState("")
    unplaced.on_scan(Scan(ScanData(ranges, 0.0, 0.1, 0.1, 4.0), "laser"))
    assert unplaced.scan_in_map().shape == (0, 2)


def test_particles_are_decimated_for_drawing_not_for_counting():
    state = RobotState("", max_particles=1000)
    cloud = np.column_stack([RNG.uniform(-2, 2, (5000, 2)), RNG.uniform(-3, 3, 5000)])
    cloud[17] = np.nan
    state.on_particles(cloud)
    assert state.particle_count == 4999 and len(state.particles) == 1000
    assert {tuple(p) for p in state.particles} <= {tuple(p) for p in cloud}
    again = RobotState("", max_particles=1000)
    again.on_particles(cloud)
    assert np.array_equal(again.particles, state.particles), "the same cloud draws the same points"
    assert len(decimate(cloud, 0)) == 0 and len(decimate(cloud[:10], 100)) == 10


def test_versions_change_only_with_their_layer():
    state = RobotState("")
    state.on_path(np.array([[0, 0], [1, 1], [np.nan, 2]]))
    assert state.versions["path"] == 1 and len(state.path) == 2 and state.versions["particles"] == 0
    state.on_goal(Pose2D(math.nan, 0, 0))
    assert state.goal is None and state.versions["goal"] == 0
    state.on_beacons([[1, 2], [3, 4]])
    state.on_beacons([[1, 2], [3, 4]])
    assert state.versions["beacons"] == 1, "the same beacons again change nothing"


def test_estimate_ellipse_and_localized_flag():
    state = RobotState("")
    assert state.localized is None and state.estimate_ellipse() is None
    state.on_estimate(Estimate(Pose2D(1.0, 1.0, 0.0), (0.04, 0.0, 0.01), True))
    ellipse = state.estimate_ellipse(sigmas=1.0)
    assert state.localized is True
    assert ellipse[:, 0].max() == pytest.approx(1.2) and ellipse[:, 1].max() == pytest.approx(1.1, abs=1e-3)


def test_trail_keeps_spacing_breaks_at_jumps_and_chunks():
    trail = Trail(spacing=0.05, chunk=10, max_chunks=3)
    assert trail.add(0.0, 0.0) and not trail.add(0.01, 0.0) and trail.add(0.06, 0.0)
    assert trail.add(3.0, 0.0), "a jump is kept, after a break"
    assert math.isnan(trail.chunks[-1][-2][0]) and trail.last() == (3.0, 0.0)
    for k in range(40):
        trail.add(3.0 + 0.1 * (k + 1), 0.0)
    assert len(trail.chunks) == 3 and trail.dropped > 0
    assert trail.chunks[-2][-1] == trail.chunks[-1][0], "chunks join"
    trail.clear()
    assert trail.chunks == [[]] and trail.last() is None


def test_a_simulator_reset_starts_a_new_trail():
    state = RobotState("", trail_spacing=0.01)
    for k in range(5):
        state.on_ground_truth(tf("map", "base_footprint", 0.1 * k, 0.0, 0.0))
        state.on_status({"steps": k})
    assert len(state.trail.chunks[-1]) == 5
    state.on_status({"steps": 0})
    assert state.trail.chunks == [[]]


def test_the_true_ring_is_taken_at_the_instant_of_the_robots_transform():
    state = RobotState("")
    for k in range(10):  # the truth runs ahead of TF: steps 0..9 known, the transform still at step 4
        state.on_ground_truth(tf("map", "base_footprint", 0.1 * k, 0.0, 0.0, stamp=0.05 * k))
    assert state.truth_at_robot_instant() == pytest.approx((0.9, 0.0, 0.0)), "no TF: the latest truth"
    assert state.drawn_offset() is None, "no TF: the disc is the truth"
    state.on_transforms(
        [tf("map", "odom", 0.02, 0.0, 0.0, stamp=0.1), tf("odom", "base_footprint", 0.4, 0.0, 0.0, stamp=0.2)]
    )
    assert state.base_stamp == pytest.approx(0.2)
    assert state.truth_at_robot_instant() == pytest.approx((0.4, 0.0, 0.0))
    assert state.drawn_offset() == pytest.approx(0.02), "the filter's 2 cm, not the 50 cm the truth ran ahead"
    versions = state.versions["truth"]
    state.on_transforms([tf("odom", "base_footprint", 0.5, 0.0, 0.0, stamp=0.25)])
    assert state.versions["truth"] > versions, "a new transform redraws the ring"
    assert state.truth_at_robot_instant() == pytest.approx((0.5, 0.0, 0.0))
    state.on_ground_truth(tf("map", "base_footprint", 0.0, 0.0, 0.0, stamp=0.0))  # time went back: a restart
    assert state.truth_at_robot_instant() == pytest.approx((0.0, 0.0, 0.0))


def test_a_fleet_robot_on_the_shared_tree_takes_its_prefixed_base_stamp():
    state = RobotState("/r2")
    state.on_ground_truth(tf("map", "r2/base_footprint", 1.0, 0.0, 0.0, stamp=1.0))
    state.on_ground_truth(tf("map", "r2/base_footprint", 2.0, 0.0, 0.0, stamp=2.0))
    state.on_transforms(
        [
            tf("r2/odom", "r2/base_footprint", 1.0, 0.0, 0.0, stamp=1.0),
            tf("r1/odom", "r1/base_footprint", 5.0, 0.0, 0.0, stamp=2.0),
        ]
    )
    assert state.base_stamp == 1.0 and state.truth_at_robot_instant() == pytest.approx((1.0, 0.0, 0.0))
