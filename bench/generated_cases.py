"""What bench_planning.py and bench_navigation.py share: the generated maze cases and the goals they pick.

Each family's seeds cycle through every corridor width x LiDAR noise pair (9 seeds cover them all) and
alternate the wall follower's hand; pillar rooms and open rooms take no width.
"""

from __future__ import annotations

import numpy as np

from amr_maps.maze_families import FAMILIES
from amr_planning.costmap import Costmap

WIDTHS = (0.35, 0.45, 0.6)
NOISES = (0.0, 0.01, 0.03)


def maze_variant(family: str, seed: int) -> tuple[dict, float, float, str]:
    """(options for maze_families.generate, corridor width, LiDAR noise, hand) of a family's seed."""
    width = WIDTHS[seed % len(WIDTHS)]
    noise = NOISES[(seed // len(WIDTHS) + FAMILIES.index(family)) % len(NOISES)]
    hand = ("right", "left")[seed % 2]
    options = {"hand": hand} if family in ("pillars", "open_room") else {"hand": hand, "width": width}
    return options, width, noise, hand


def far_free_point(costmap: Costmap, start, rng: np.random.Generator | None = None) -> np.ndarray:
    """A free cell reachable from start: the farthest (rng None) or a random one over 1 m away."""
    from scipy.ndimage import label

    regions, _ = label(~costmap.lethal)
    row, col = costmap.nearest_free(*costmap.cell(*start))
    cells = np.argwhere(regions == regions[row, col])
    points = costmap.centre(cells[:, 0], cells[:, 1])
    distance = np.hypot(*(points - np.asarray(start)).T)
    if rng is None:
        return points[int(np.argmax(distance))]
    far = np.flatnonzero(distance > 1.0)
    return points[rng.choice(far)] if far.size else points[int(np.argmax(distance))]
