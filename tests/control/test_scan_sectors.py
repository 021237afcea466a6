"""Beam windows located by angle, REP 117 readings, line fits and the straight-ahead clearance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.control import cast, corridor

from amr_control.scan_sectors import Footprint, ScanData, SectorReader, Sectors

READER = SectorReader(
    Sectors(math.radians(15.0), math.radians(20.0), math.radians(5.0)), Footprint(radius=0.105, lidar_x=-0.032)
)


@pytest.mark.parametrize("beams, angle_min", [(240, 0.0), (360, 0.0), (360, -math.pi), (720, -math.pi / 3), (100, 1.0)])
def test_windows_are_located_by_angle_whatever_the_layout(beams, angle_min):
    r = READER.read(cast(corridor(left=0.25, right=0.35, front=0.6), beams=beams, angle_min=angle_min))
    tolerance = 0.25 * (2.0 * math.pi / beams)  # a window edge may fall either side of a beam
    assert r.front == pytest.approx(0.6, abs=tolerance)
    assert r.ahead == pytest.approx(0.6, abs=2e-3)
    assert r.left == pytest.approx(0.25, abs=1e-3)
    assert r.right == pytest.approx(0.35, abs=1e-3)
    assert r.left_abeam == pytest.approx(0.25, abs=3e-3)
    assert r.right_abeam == pytest.approx(0.35, abs=3e-3)


def test_window_sizes_follow_the_beam_count():
    assert READER.read(cast(corridor(), beams=240)).window_beams == (21, 7, 7)  # 1.5 deg beams
    assert READER.read(cast(corridor(), beams=360, angle_min=-math.pi)).window_beams == (31, 11, 11)


def test_rep117_and_invalid_readings():
    ranges = np.full(360, 2.0)
    ranges[0:3] = np.nan  # ignored
    ranges[357:360] = 0.0  # the LDS writes 0 for a failed beam: below range_min, ignored
    ranges[3] = 1e30  # beyond range_max: ignored
    ranges[4] = np.inf  # no return: free
    ranges[90] = -np.inf  # too close: counts as range_min
    ranges[270] = 0.5
    r = READER.read(ScanData(ranges, 0.0, math.radians(1.0), 0.12, 3.5))
    assert r.front == 2.0
    assert r.left == pytest.approx(0.12)
    assert r.right == 0.5
    assert r.usable_beams == 360 - 3 - 3 - 1


def test_a_window_without_usable_beam_reads_inf():
    ranges = np.full(360, np.nan)
    ranges[180] = 1.0  # only a beam behind the robot
    r = READER.read(ScanData(ranges, 0.0, math.radians(1.0), 0.12, 3.5))
    assert (r.front, r.left, r.right) == (math.inf, math.inf, math.inf)
    assert r.usable_beams == 1
    assert r.left_fit is None and r.right_fit is None


def test_bad_metadata_is_tolerated_or_reported():
    assert "non-empty" in READER.read(ScanData([], 0.0, 0.01))
    assert "non-empty" in READER.read(ScanData([[1.0, 2.0]], 0.0, 0.01))
    assert "unreadable" in READER.read(ScanData(["a", "b"], 0.0, 0.01))
    assert "non-empty" in READER.read(ScanData(None, 0.0, 0.01))
    assert "non-finite" in READER.read(ScanData([1.0, 1.0], 0.0, math.nan))
    assert "is 0" in READER.read(ScanData([1.0, 1.0], 0.0, 0.0))
    r = READER.read(ScanData([0.5] * 360, 0.0, math.radians(1.0), math.nan, math.nan))
    assert r.front == 0.5  # NaN limits: no range filtering


@pytest.mark.parametrize("skew_deg", [-25.0, -10.0, 0.0, 7.0, 20.0])
def test_line_fit_gives_the_wall_angle_and_perpendicular_distance(skew_deg):
    r = READER.read(cast(corridor(left=0.3, right=0.2), heading=math.radians(skew_deg)))
    for fit, distance in ((r.left_fit, 0.3), (r.right_fit, 0.2)):
        assert fit.distance == pytest.approx(distance, abs=1e-9)
        assert fit.angle == pytest.approx(-math.radians(skew_deg), abs=1e-9)
        assert fit.rms < 1e-6


def test_line_fit_of_a_corner_scatters():
    # Close to a concave corner the right window sees the wall alongside and the wall ahead.
    walls = [(-5.0, -0.2, 0.05, -0.2), (0.05, -0.2, 0.05, 0.5)]
    fit = READER.read(cast(walls)).right_fit
    assert fit.rms > 0.01


def test_clearance_is_free_travel_of_the_disc():
    r = READER.read(cast(corridor(front=0.5)))
    # wall 0.5 from the LiDAR, which is 3.2 cm behind the axle (the 5-beam mean reads a flat wall < 1 mm further)
    assert r.clearance == pytest.approx(0.5 - 0.032 - 0.105, abs=1e-3)
    alongside = READER.read(cast(corridor(left=0.11, right=0.3)))
    assert alongside.clearance == math.inf  # a wall alongside does not limit straight travel


def test_clearance_sees_an_oblique_obstacle_the_front_window_misses():
    post = (0.08, -0.08)  # robot frame: ahead and to the right, 35 deg off the LiDAR's axis
    lidar = (post[0] + 0.032, post[1])
    walls = [(lidar[0] - 0.01, lidar[1] - 0.01, lidar[0] + 0.01, lidar[1] + 0.01)]
    r = READER.read(cast(walls, beams=720))
    assert r.front == math.inf
    assert r.clearance < 0.02
    assert r.clearance_side == -1


@pytest.mark.parametrize("skew_deg", [0.0, 8.0])
@pytest.mark.parametrize("noise", [0.0, 0.03])
def test_wall_end_is_where_the_passed_wall_ends_not_where_it_resumes(skew_deg, noise):
    # A right wall 0.2 m away ending 5 cm behind the LiDAR, resuming 0.35 m further on (a side
    # corridor): the robot (turned skew_deg clockwise of the walls) has passed the first end.
    skew = math.radians(skew_deg)
    end, resume = -0.05, 0.30
    walls = [(-3.0, -0.2, end, -0.2), (end, -0.2, end, -0.26), (resume, -0.2, 3.0, -0.2), (-3.0, 0.5, 3.0, 0.5)]
    scan = cast(walls, beams=360, heading=-skew)
    if noise:
        ranges = np.asarray(scan.ranges) + np.random.default_rng(3).normal(0.0, noise, len(scan.ranges))
        scan = ScanData(ranges, scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max)
    reader = SectorReader(
        Sectors(math.radians(15), math.radians(20), math.radians(5)), Footprint(0.105, -0.032, 0.01), 3
    )
    reader.read(scan)
    found = reader.wall_end(-1.0, 0.2, skew)
    assert found == pytest.approx(-0.032 + end, abs=0.01 + noise)  # rotation-centre frame, along the walls
    assert reader.wall_end(-1.0, 0.6, skew) is None  # nothing on that line
