"""OccupancyGrid: the nav_msgs conventions (row 0 at the bottom, origin at cell (0,0)'s corner)."""

import numpy as np
import pytest

from amr_maps.occupancy_grid import MapError, OccupancyGrid


def grid():
    data = np.zeros((4, 6), dtype=np.int8)
    data[0, 5] = 100  # bottom-right cell
    data[3, 0] = -1  # top-left cell
    return OccupancyGrid(data, 0.5, (-1.0, 2.0, 0.0))


def test_cells_and_points_follow_the_message_layout():
    g = grid()
    assert (g.width, g.height) == (6, 4)
    assert g.bounds == (-1.0, 2.0, 2.0, 4.0)
    row, col = g.world_to_cell(1.9, 2.1)
    assert (int(row), int(col)) == (0, 5)
    assert g.data.ravel()[int(row) * g.width + int(col)] == 100
    x, y = g.cell_to_world(3, 0)
    assert (float(x), float(y)) == (-0.75, 3.75)
    assert g.occupied().sum() == 1 and g.free().sum() == 22
    assert not bool(g.inside(*g.world_to_cell(-1.01, 3.0)))


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"data": np.zeros((0, 3), np.int8)}, "non-empty"),
        ({"data": np.full((2, 2), 101)}, "0..100"),
        ({"data": np.zeros((2, 2), np.int8), "resolution": 0.0}, "resolution"),
        ({"data": np.zeros((2, 2))}, "integers"),
        ({"data": np.zeros((2, 2), np.int8), "resolution": float("nan")}, "resolution"),
        ({"data": np.zeros((2, 2), np.int8), "origin": (0.0, 0.0, 0.3)}, "yaw"),
    ],
)
def test_bad_grids_are_refused_naming_what_is_wrong(kwargs, words):
    args = {"resolution": 0.05, **kwargs}
    with pytest.raises(MapError, match=words):
        OccupancyGrid(**args)
