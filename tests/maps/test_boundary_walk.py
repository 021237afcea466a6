"""Boundary walk: the length an ideal wall follower walks, in the direction its hand dictates."""

from __future__ import annotations

import pytest

from amr_maps.boundary_walk import BoundaryWalk
from amr_maps.world import world_from_dict

HALF, THICKNESS, OFFSET = 2.0, 0.05, 0.105


def _room_quads():
    h = HALF
    world = world_from_dict(
        {
            "wall_thickness": THICKNESS,
            "walls": [[-h, -h, h, -h], [h, -h, h, h], [h, h, -h, h], [-h, h, -h, -h]],
            "start": [0.0, 0.0, 0.0],
        }
    )
    return world.polygons


def test_a_lap_of_a_square_room_is_the_perimeter_of_the_offset_square():
    walk = BoundaryWalk(_room_quads(), (0.0, -1.5), "right", offset=OFFSET)
    side = 2.0 * (HALF - 0.5 * THICKNESS - OFFSET)
    assert walk.lap == pytest.approx(4.0 * side, rel=0.03)
    assert walk.approach == pytest.approx(HALF - 0.5 * THICKNESS - OFFSET - 1.5, abs=0.03)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_the_hand_decides_which_way_round_the_walk_goes(hand):
    # Start by the south wall heading east: a right hand keeps it on the right, walking
    # east then north (counter-clockwise round the room); a left hand walks west first.
    # (0.1 m reach: the walk stops that much short of each goal.)
    walk = BoundaryWalk(_room_quads(), (0.0, -1.5), hand, offset=OFFSET)
    east, west = walk.length_to(1.8, 0.0, 0.1), walk.length_to(-1.8, 0.0, 0.1)
    side = 2.0 * (HALF - 0.5 * THICKNESS - OFFSET)
    near, far = (east, west) if hand == "right" else (west, east)
    assert near == pytest.approx(walk.approach + side, abs=0.1)
    assert far == pytest.approx(walk.approach + 3.0 * side, abs=0.15)  # the long way: three sides


def test_a_point_off_the_curve_is_never_reached():
    walk = BoundaryWalk(_room_quads(), (0.0, -1.5), "right", offset=OFFSET)
    assert walk.length_to(0.0, 0.0, 0.3) == float("inf")


def test_a_bad_hand_is_refused():
    with pytest.raises(ValueError, match="hand"):
        BoundaryWalk(_room_quads(), (0.0, 0.0), "middle")
