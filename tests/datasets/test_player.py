"""LogPlayer: which scans, at which stamps, with which odometry; slices and laps."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest
from support.carmen_logs import write_log

from amr_datasets.carmen import read_carmen
from amr_datasets.odometry import OdometryNoiseModel, synthesize_odometry
from amr_datasets.player import LogPlayer
from amr_util.geometry import relative_pose


@pytest.fixture
def log(tmp_path):
    path = tmp_path / "small.log"
    write_log(path, count=12, period=0.5)
    return read_carmen(path)


def test_a_slice_plays_its_scans_at_their_stamps_with_odometry_from_its_first_pose(log):
    player = LogPlayer(log, OdometryNoiseModel.perfect(), start=3, count=5)
    steps = [player.step(k) for k in range(len(player))]
    assert len(player) == 5 and [s.scan_index for s in steps] == [3, 4, 5, 6, 7] and not player.has(5)
    assert [s.stamp for s in steps] == pytest.approx([11.5, 12.0, 12.5, 13.0, 13.5])
    assert steps[0].odom == (0.0, 0.0, 0.0) and steps[0].odom_twist == (0.0, 0.0, 0.0)
    assert steps[2].scan is log.scans[5].scan and steps[2].pose == pytest.approx(log.scans[5].pose)
    for a, b in pairwise(steps):
        assert relative_pose(a.odom, b.odom) == pytest.approx(relative_pose(a.pose, b.pose), abs=1e-9)
    assert steps[1].odom_twist[0] == pytest.approx(0.5 / 0.5)  # 0.5 m in 0.5 s
    with pytest.raises(IndexError):
        player.step(5)


def test_the_odometry_is_the_seeded_synthesis(log):
    noise = OdometryNoiseModel()
    player = LogPlayer(log, noise, seed=7)
    expected = synthesize_odometry(log.poses(), noise, 7)
    np.testing.assert_allclose([player.step(k).odom for k in range(len(player))], expected)


def test_stamps_at_zero_are_moved_to_start_at_one_second(tmp_path):
    path = tmp_path / "nostamps.log"
    write_log(path, count=4, stamps=False)
    player = LogPlayer(read_carmen(path))
    assert [player.stamp(k) for k in range(4)] == [1.0, 2.0, 3.0, 4.0]


def test_a_loop_goes_on_in_time_and_carries_the_odometry_by_the_jump(log):
    player = LogPlayer(log, OdometryNoiseModel.perfect(), count=4, loop=True)
    steps = [player.step(k) for k in range(10)]
    assert player.has(1000) and [s.lap for s in steps] == [0, 0, 0, 0, 1, 1, 1, 1, 2, 2]
    assert (np.diff([s.stamp for s in steps]) > 0).all() and steps[4].stamp == pytest.approx(12.0)
    jump = relative_pose(steps[3].pose, steps[4].pose)
    assert relative_pose(steps[3].odom, steps[4].odom) == pytest.approx(jump, abs=1e-9)
    assert steps[4].odom_twist == (0.0, 0.0, 0.0)
    noisy = LogPlayer(log, OdometryNoiseModel(), count=4, loop=True)
    first, second = (
        [relative_pose(noisy.step(k).odom, noisy.step(k + 1).odom) for k in (lap, lap + 1)] for lap in (0, 4)
    )
    assert first != second  # each lap its own noise (seed + lap)


@pytest.mark.parametrize("start, count", [(12, 0), (-1, 0), (0, -2)])
def test_an_empty_or_negative_slice_is_refused(log, start, count):
    with pytest.raises(ValueError):
        LogPlayer(log, start=start, count=count)
