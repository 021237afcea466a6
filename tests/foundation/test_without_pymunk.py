"""A localizer and a planner import and run on a machine without pymunk or the simulator (a real robot).

A child Python starts with a meta-path finder that refuses pymunk and amr_simulation, then imports the
particle filter, the beacon localizer and the planner (libraries and nodes), localizes on a shipped world
from scans ray-cast with amr_maps' numpy caster along a path the planner plans on the same grid.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

from amr_util.environment import child_environment

CHILD = textwrap.dedent("""
    import importlib, json, math, sys

    BLOCKED = {"pymunk", "amr_simulation"}

    class Unavailable:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in BLOCKED:
                raise ModuleNotFoundError(f"No module named {name!r} (blocked by the test)", name=name)
            return None

    sys.meta_path.insert(0, Unavailable())
    try:
        importlib.import_module("pymunk")
    except ModuleNotFoundError:
        pass
    else:
        raise SystemExit("the blocker let pymunk through")

    nodes = ["amr_localization.particle_filter_node", "amr_localization.beacon_localizer_node",
             "amr_planning.planner_node", "amr_control.wall_follower_node", "amr_control.path_follower_node",
             "amr_maps.map_server_node", "amr_turtlebot3.odometry_node", "amr_navigation.navigator_node",
             "amr_navigation.loop"]
    for name in nodes:
        importlib.import_module(name)

    import numpy as np
    from amr_localization.particle_filter import ParticleFilter
    from amr_localization.particle_filter_config import ParticleFilterConfig
    from amr_maps.rasterize import rasterize_world
    from amr_maps.raycast import NumpyRayCaster
    from amr_maps.world import load_world, resolve_world_path
    from amr_planning.planner import Planner, PlannerConfig
    from amr_util.scan import ScanData

    world = load_world(resolve_world_path("hard_maze.yaml"))
    grid = rasterize_world(world, 0.025)
    caster = NumpyRayCaster(world.faces)
    x, y, theta = world.start
    beams = 360
    increment = 2 * math.pi / beams

    def scan(x, y, theta):
        ranges = caster.cast(x, y, theta, increment, beams, 3.5)
        ranges[ranges > 3.5] = math.inf
        return ScanData(ranges, 0.0, increment, 0.12, 3.5)

    path = Planner(grid, PlannerConfig()).plan((x, y), (world.goal.x, world.goal.y))
    pf = ParticleFilter(grid, ParticleFilterConfig(seed=1), range_max=3.5)
    pf.initialize_pose(x + 0.1, y - 0.05, theta + 0.1, np.diag([0.02, 0.02, 0.02]))
    for (x0, y0), (x, y) in zip(path[:-4:4], path[4::4]):  # the robot drives the path
        theta = math.atan2(y - y0, x - x0)
        estimate = pf.update((x, y, theta), scan(x, y, theta))  # odometry: exact, odom = map
    pose = estimate.pose
    print(json.dumps({
        "error": math.hypot(pose.x - x, pose.y - y),
        "heading_error": abs(math.remainder(pose.theta - theta, 2 * math.pi)),
        "path": [path[0].tolist(), path[-1].tolist(), len(path)],
        "goal": [world.goal.x, world.goal.y, world.goal.radius],
        "loaded": sorted(name for name in sys.modules if name.split(".")[0] in BLOCKED),
    }))
""")


def test_localizer_and_planner_run_without_pymunk_and_the_simulator():
    result = subprocess.run(
        [sys.executable, "-c", CHILD], env=child_environment(), capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr[-3000:]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["loaded"] == []
    assert report["error"] <= 0.05 and report["heading_error"] <= 0.05, report
    start, end, points = report["path"]
    goal_x, goal_y, radius = report["goal"]
    assert points >= 2 and ((end[0] - goal_x) ** 2 + (end[1] - goal_y) ** 2) ** 0.5 <= radius, report
