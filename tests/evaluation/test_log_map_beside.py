"""A log's map with another building beside it (amr_evaluation.log_localization.log_map_beside): both buildings
mapped, apart, the log's own part as its own map has it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.carmen_logs import write_log

from amr_datasets.carmen import read_carmen
from amr_evaluation.log_localization import MAP_RANGE, log_map, log_map_beside


@pytest.fixture()
def logs(tmp_path):
    write_log(tmp_path / "a.log", count=16)
    write_log(tmp_path / "b.log", count=24)
    return read_carmen(tmp_path / "a.log"), read_carmen(tmp_path / "b.log")


def known_columns_x(grid) -> np.ndarray:
    """x of every column with a known cell."""
    columns = np.flatnonzero((grid.data >= 0).any(axis=0))
    return grid.origin[0] + (columns + 0.5) * grid.resolution


def test_the_other_building_lies_beyond_the_gap_and_the_logs_own_map_is_unchanged(logs):
    log, other = logs
    own = log_map(log)
    both = log_map_beside(log, other, gap=20.0)
    x = known_columns_x(both)
    own_x = known_columns_x(own)
    # the other building's cells start at least the gap beyond the log's own (each scan reaches MAP_RANGE at most)
    beyond = x[x > own_x.max() + 0.5 * both.resolution]
    assert len(beyond) > 0
    assert beyond.min() - own_x.max() >= 20.0 - both.resolution
    shift = log.poses()[:, 0].max() - other.poses()[:, 0].min() + 2.0 * MAP_RANGE + 20.0
    assert beyond.max() <= other.poses()[:, 0].max() + shift + MAP_RANGE + both.resolution
    # the log's own part: cell for cell its own map (the other's scans never reach it)
    rows, cols = np.nonzero(own.data >= 0)
    wx, wy = own.cell_to_world(rows, cols)
    brow, bcol = (np.asarray(v, dtype=int) for v in both.world_to_cell(wx, wy))
    assert np.array_equal(both.data[brow, bcol], own.data[rows, cols])


def test_a_gap_that_is_not_a_distance_is_refused(logs):
    log, other = logs
    for gap in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="gap"):
            log_map_beside(log, other, gap=gap)
