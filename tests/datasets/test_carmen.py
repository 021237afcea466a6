"""The CARMEN reader: scans, poses, stamps and no-return readings of a written log and of the shipped ones;
malformed lines named by file and line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from support.carmen_logs import MAX_RANGE, SHARED, flaser_line, ranges_of, write_log

from amr_datasets.carmen import DatasetError, detect_max_range, log_name, played_backwards, read_carmen, thinned
from amr_util.geometry import wrap_angle


def test_a_written_log_reads_back_scan_for_scan(tmp_path):
    path = tmp_path / "small.log"
    poses = write_log(path, count=20, beams=181)
    log = read_carmen(path)
    assert len(log) == 20 and log.message == "FLASER" and log.has_stamps and log.stamp_problem == ""
    assert log.ignored == {"NEFF": 20, "ODOM": 20, "PARAM": 1}
    np.testing.assert_allclose(log.poses()[:, :2], poses[:, :2], atol=1e-6)
    np.testing.assert_allclose(wrap_angle(log.poses()[:, 2] - poses[:, 2]), 0.0, atol=1e-6)
    np.testing.assert_allclose(log.stamps(), 10.0 + 0.2 * np.arange(20), atol=1e-9)
    assert log.max_range == MAX_RANGE
    scan = log.scans[3].scan
    assert scan.angle_min == pytest.approx(-math.pi / 2) and scan.angle_increment == pytest.approx(math.pi / 180)
    assert scan.range_max == MAX_RANGE and len(scan.ranges) == 181
    expected = np.array(ranges_of(3, 181))
    no_return = expected >= MAX_RANGE
    assert np.isposinf(scan.ranges[no_return]).all() and no_return.sum() > 10
    np.testing.assert_allclose(scan.ranges[~no_return], expected[~no_return])
    assert [scan.line for scan in log.scans[:4]] == [6, 10, 13, 16]  # 4 header lines, ODOM/FLASER/NEFF, blanks


def test_gzip_is_read_by_its_content_and_180_beams_are_one_degree_apart(tmp_path):
    path = tmp_path / "small.log"  # gzip whatever the name says
    write_log(path, count=6, beams=180, gzipped=True)
    log = read_carmen(path)
    assert len(log) == 6
    scan = log.scans[0].scan
    assert scan.angle_increment == pytest.approx(math.pi / 180) and len(scan.ranges) == 180


def test_361_beams_are_half_a_degree_apart_and_a_fov_param_is_read(tmp_path):
    path = tmp_path / "half.log"
    write_log(path, count=4, beams=361)
    assert read_carmen(path).scans[0].scan.angle_increment == pytest.approx(math.pi / 360)
    wide = tmp_path / "wide.log"
    write_log(wide, count=4, beams=271, extra=())
    text = "PARAM laser_front_laser_fov 270 nohost 0\n" + wide.read_text()
    wide.write_text(text)
    scan = read_carmen(wide).scans[0].scan
    assert scan.angle_min == pytest.approx(-math.radians(135)) and scan.angle_increment == pytest.approx(
        math.radians(1.0)
    )


def test_missing_stamps_are_synthesized_one_second_apart(tmp_path):
    path = tmp_path / "nostamps.log"
    write_log(path, count=5, stamps=False)
    log = read_carmen(path)
    assert not log.has_stamps and "no timestamp on line" in log.stamp_problem
    np.testing.assert_array_equal(log.stamps(), [0.0, 1.0, 2.0, 3.0, 4.0])
    zeros = tmp_path / "zeros.log"
    lines = [flaser_line(ranges_of(i, 181), (0.1 * i, 0.0, 0.0), 0.0) for i in range(4)]
    zeros.write_text("\n".join(lines) + "\n")
    log = read_carmen(zeros)
    assert not log.has_stamps and "every timestamp is 0" in log.stamp_problem
    np.testing.assert_array_equal(log.stamps(), [0.0, 1.0, 2.0, 3.0])


def test_a_few_stamps_going_back_are_repaired_not_dropped(tmp_path):
    path = tmp_path / "back.log"
    stamps = [1.0, 2.0, 3.0, 2.5, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0]
    lines = [flaser_line(ranges_of(i, 181), (0.1 * i, 0.0, 0.0), stamp) for i, stamp in enumerate(stamps)]
    path.write_text("\n".join(lines) + "\n")
    log = read_carmen(path)
    assert log.has_stamps and "1 timestamps did not increase (lines 4)" in log.stamp_problem
    assert log.stamps()[3] == pytest.approx(3.5) and (np.diff(log.stamps()) > 0).all()  # between 3 and 4


def test_robotlaser1_lines_carry_their_own_angles_and_max_range(tmp_path):
    path = tmp_path / "robot.log"
    lines = []
    for i in range(5):
        ranges = [2.0 + 0.1 * k for k in range(9)] + [30.0]
        lines.append(
            "ROBOTLASER1 0 -2.0 4.0 0.4 30.0 0.01 0 10 "
            + " ".join(f"{r:g}" for r in ranges)
            + f" 0 {0.5 * i} 0.1 0.2 {0.5 * i - 0.1} 0.1 0.2 0.3 0.0 0.5 0.5 0.0 {100 + i} host {100 + i}"
        )
        lines.append(f"RAWLASER1 0 -2.0 4.0 0.4 30.0 0.01 0 2 1 1 0 {100 + i} host {100 + i}")
    path.write_text("\n".join(lines) + "\n")
    log = read_carmen(path)
    assert log.message == "ROBOTLASER1" and len(log) == 5 and log.ignored == {"RAWLASER1": 5}
    scan = log.scans[2]
    assert scan.scan.angle_min == -2.0 and scan.scan.angle_increment == pytest.approx(0.4)
    assert scan.pose == pytest.approx((1.0, 0.1, 0.2)) and scan.odom == pytest.approx((0.9, 0.1, 0.2))
    assert scan.stamp == 102.0
    assert log.max_range == 30.0 and math.isinf(scan.scan.ranges[-1])


@pytest.mark.parametrize(
    "line, words",
    [
        ("FLASER 181 1 2 3", "181 ranges: expected 181 values, the line has 3"),
        ("FLASER 3 1.0 2.0 3.0 0.0 0.0", "expected x y theta after the 3 ranges"),
        ("FLASER 3 1.0 abc 3.0 0.0 0.0 0.0", "'abc' is not a number"),
        ("FLASER 3 1.0 nan 3.0 0.0 0.0 0.0", "NaN"),
        ("FLASER 3 1.0 -2 3.0 0.0 0.0 0.0", "negative range -2"),
        ("FLASER x 1.0", "beam count: expected a positive integer, got 'x'"),
        ("FLASER 3 1.0 2.0 3.0 0.0 0.0 inf", "the pose is not finite"),
        ("FLASER 3 1.0 2.0 3.0 0.0 0.0 0.0 0 0 0 notastamp host 1", "timestamp 'notastamp' is not a number"),
        ("flaser 3 1.0 2.0 3.0 0.0 0.0 0.0", "'flaser': not a CARMEN message type"),
        ("12.5 3.0", "'12.5': not a CARMEN message type"),
    ],
)
def test_a_malformed_line_names_file_line_and_problem(tmp_path, line, words):
    path = tmp_path / "bad.log"
    good = flaser_line(ranges_of(0, 181), (0.0, 0.0, 0.0), 1.0)
    path.write_text(f"# header\n{good}\n\n{line}\n{good}\n")
    with pytest.raises(DatasetError) as error:
        read_carmen(path)
    assert f"{path}:4: " in str(error.value) and words in str(error.value)


def test_unknown_message_types_are_counted_and_a_log_without_scans_is_refused(tmp_path):
    path = tmp_path / "other.log"
    path.write_text("GPSNMEAGGA 1 2 3\nODOM 0 0 0 0 0 0 1 h 1\n")
    with pytest.raises(
        DatasetError,
        match=r"no FLASER or ROBOTLASER1 or RLASER or ROBOTLASER2 line \(found: "
        r"GPSNMEAGGA 1, ODOM 1\)",
    ):
        read_carmen(path)
    with pytest.raises(DatasetError, match="no such file"):
        read_carmen(tmp_path / "missing.log.gz")


def test_max_range_detection_takes_the_repeated_top_cluster_and_nothing_else():
    rng = np.random.default_rng(0)
    real = np.round(rng.uniform(0.3, 30.0, 50_000), 3)
    assert (
        detect_max_range(np.concatenate([real, np.full(400, 32.767), np.full(300, 32.763), np.full(20, 32.759)]))
        == 32.759
    )
    assert detect_max_range(np.concatenate([real, np.full(400, 51.05), np.full(40, 51.1), [49.9, 49.95]])) == 51.05
    assert detect_max_range(real) is None  # no value stands out
    quantized = np.round(rng.uniform(0.3, 8.0, 50_000), 1)  # every value repeats: none is a spike
    assert detect_max_range(quantized) is None


def test_max_range_can_be_given_or_switched_off(tmp_path):
    path = tmp_path / "small.log"
    write_log(path, count=6)
    assert read_carmen(path, max_range=2.0).scans[0].scan.range_max == 2.0
    log = read_carmen(path, max_range=math.inf)
    assert log.max_range is None and np.isfinite(log.scans[0].scan.ranges).all()
    assert log.scans[0].scan.range_max == MAX_RANGE  # the largest reading


@pytest.mark.skipif(SHARED is None, reason="no copy of shared/data/carmen on this machine")
@pytest.mark.parametrize(
    "name, count, beams, max_range, stamped",
    [
        ("intel", 910, 180, 81.83, True),
        ("aces", 440, 180, 50.0, True),
        ("fhw", 488, 180, 51.05, True),
        ("orebro", 237, 181, 32.759, False),
    ],
)
def test_the_shipped_logs(name, count, beams, max_range, stamped):
    log = read_carmen(SHARED / f"{name}-corrected.log.gz")
    assert (len(log), log.max_range, log.has_stamps) == (count, max_range, stamped)
    assert {len(scan.scan.ranges) for scan in log.scans} == {beams}
    assert (np.diff(log.stamps()) > 0).all()
    steps = np.hypot(*np.diff(log.poses()[:, :2], axis=0).T)
    assert 0.3 < np.median(steps) < 1.5  # keyframes about 1 m apart
    ranges = np.concatenate([scan.scan.ranges for scan in log.scans])
    assert not np.isnan(ranges).any() and np.isposinf(ranges).sum() >= 600


def test_a_logs_name_is_its_file_names_first_word():
    assert [log_name(Path(n)) for n in ("intel-corrected.log.gz", "orebro.log", "/data/fr079-sm.log")] == [
        "intel",
        "orebro",
        "fr079",
    ]


def test_a_log_played_backwards_has_its_scans_reversed_and_its_stamps_growing(tmp_path):
    path = tmp_path / "small.log"
    write_log(path, count=20, period=0.3)
    log = read_carmen(path)
    backwards = played_backwards(log)
    assert [s.pose for s in backwards.scans] == [s.pose for s in reversed(log.scans)]
    stamps = backwards.stamps()
    assert np.all(np.diff(stamps) > 0) and stamps[0] == log.stamps()[0] and stamps[-1] == log.stamps()[-1]
    assert np.allclose(np.diff(stamps), np.diff(log.stamps())[::-1])
    assert [s.pose for s in thinned(log, 2).scans] == [s.pose for s in log.scans[::2]]
    with pytest.raises(DatasetError, match="stride"):
        thinned(log, 0)
