"""Small costmaps the fleet tests share (tests/navigation)."""

from __future__ import annotations

from amr_maps.rasterize import rasterize_world
from amr_maps.world import world_from_dict
from amr_planning.costmap import Costmap


def ring_costmap() -> Costmap:
    """A ring corridor 0.4 m wide round a 1.6 m square block."""
    walls = [
        [-1.2, -1.2, 1.2, -1.2],
        [1.2, -1.2, 1.2, 1.2],
        [1.2, 1.2, -1.2, 1.2],
        [-1.2, 1.2, -1.2, -1.2],
        [-0.8, -0.8, 0.8, -0.8],
        [0.8, -0.8, 0.8, 0.8],
        [0.8, 0.8, -0.8, 0.8],
        [-0.8, 0.8, -0.8, -0.8],
    ]
    world = world_from_dict({"name": "ring", "wall_thickness": 0.05, "walls": walls, "start": [-1.0, -1.0, 0]})
    return Costmap(rasterize_world(world, 0.02))
