"""Where a fleet starts and where each robot is sent, on any world: `with_robots` places robots r1, r2, ... spread
over the free space a robot can drive through, each sent to the next one's start (every path runs against another
robot's). Used by the fleet harness (amr_evaluation.fleet_navigation), the fleet planner's and coordinator's tests
and the benches."""

from __future__ import annotations

import math

import numpy as np

from amr_maps.rasterize import rasterize_world
from amr_maps.world import world_from_dict
from amr_planning.costmap import Costmap

MIN_SEPARATION = 0.7
"""m between any two starts placed by with_robots."""
START_CLEARANCE = 0.16
"""m from a placed start to the nearest wall (the robot's radius and 5.5 cm)."""
GOAL_RADIUS = 0.15
"""m, each robot's goal region."""


def with_robots(data: dict, robots: int, seed: int, resolution: float = 0.025) -> dict:
    """The world dict `data` (its start and goal dropped) with `robots` robots r1, r2, ... placed on free cells
    spread over it (farthest-point sampling on the planner's costmap from a random first cell, at least
    MIN_SEPARATION apart, START_CLEARANCE from walls, random headings, all from `seed`), each sent to the next
    one's start (the last to the first's): every path runs against another robot's. Every start lies in the
    largest region of the free space a robot can drive through (8-connected cells clear of the robot's radius, as
    the planner's A* moves): a closed pocket (the `dead_ends` family draws walled cells) gets no robot, so every
    goal can be reached. ValueError if they do not fit."""
    if robots < 1:
        raise ValueError(f"robots: must be at least 1, got {robots}")
    data = {key: value for key, value in data.items() if key not in ("start", "goal", "robots")}
    probe = world_from_dict({**data, "start": [0.0, 0.0, 0.0]})  # only the solids matter here
    costmap = Costmap(rasterize_world(probe, resolution))
    regions = costmap.regions()
    largest = 1 + int(np.argmax(np.bincount(regions.ravel())[1:])) if regions.max() > 0 else 0
    rows, cols = np.nonzero((costmap.clearance >= START_CLEARANCE) & (regions == largest))
    if len(rows) == 0:
        raise ValueError(f"{data.get('name', 'world')}: no free cell {START_CLEARANCE} m from the walls")
    points = costmap.centre(rows, cols)
    rng = np.random.default_rng([seed, robots])
    chosen = [points[rng.integers(len(points))]]
    distance = np.hypot(*(points - chosen[0]).T)
    while len(chosen) < robots:
        index = int(np.argmax(distance))
        if distance[index] < MIN_SEPARATION:
            raise ValueError(f"{data.get('name', 'world')}: no room for {robots} robots {MIN_SEPARATION} m apart")
        chosen.append(points[index])
        distance = np.minimum(distance, np.hypot(*(points - points[index]).T))
    starts = [chosen[i] for i in rng.permutation(robots)]
    data["robots"] = [
        {
            "name": f"r{i + 1}",
            "start": [float(s[0]), float(s[1]), float(rng.uniform(-math.pi, math.pi))],
            "goal": [float(starts[(i + 1) % robots][0]), float(starts[(i + 1) % robots][1]), GOAL_RADIUS],
        }
        for i, s in enumerate(starts)
    ]
    return data
