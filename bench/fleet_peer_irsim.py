"""IR-SIM on bench_fleet.py's scene: run by any Python that has ir-sim (it imports no amr package).

    python bench/fleet_peer_irsim.py < scene.json > result.json

The scene (JSON on stdin) is what bench_fleet.scene() made: the room's solids as axis-aligned boxes,
the robots' starts, radius, speed limits, LiDAR (beams, range), dt, steps and repeats. Each robot is
an IR-SIM diff-drive disc with a 360-degree lidar2d of the same beams and range, driven by the same
bump-and-turn rule from its own scan as our robots; only env.step() is timed (CPU and wall clock, as bench_fleet.py).
Prints {"version": ..., "runs": [{"robots": n, "seconds": best CPU s, "wall": best wall s, "steps": steps,
"collisions": c}, ...]}.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml


def world_yaml(scene: dict, count: int) -> dict:
    xmin, ymin, xmax, ymax = scene["extent"]
    robots = scene["starts"][:count]
    return {
        "world": {
            "height": ymax - ymin,
            "width": xmax - xmin,
            "offset": [xmin, ymin],
            "step_time": scene["dt"],
            "sample_time": scene["dt"],
            "collision_mode": "stop",
        },
        "robot": [
            {
                "number": count,
                "distribution": {"name": "manual"},
                "kinematics": {"name": "diff"},
                "shape": {"name": "circle", "radius": scene["radius"]},
                "state": [list(start) for start in robots],
                "goal": [[x, y, 0.0] for x, y, _ in robots],
                "vel_min": [-scene["max_linear"], -scene["max_angular"]],
                "vel_max": [scene["max_linear"], scene["max_angular"]],
                "sensors": [
                    {
                        "name": "lidar2d",
                        "range_min": scene["range_min"],
                        "range_max": scene["range_max"],
                        "angle_range": 2.0 * math.pi,
                        "number": scene["beams"],
                        "noise": False,
                    }
                ],
            }
        ],
        "obstacle": [
            {
                "shape": {"name": "rectangle", "length": x1 - x0, "width": y1 - y0},
                "state": [0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0],
                "static": True,
            }
            for x0, y0, x1, y1 in scene["boxes"]
        ],
    }


def bump_and_turn(ranges: np.ndarray, angles: np.ndarray) -> tuple[float, float]:
    """bench_fleet.bump_and_turn on IR-SIM's beam angles (its fan starts behind the robot)."""
    front = np.abs((angles + math.pi) % (2.0 * math.pi) - math.pi) < math.pi / 8.0
    return (0.0, 1.5) if np.any(ranges[front] < 0.3) else (0.2, 0.0)


def run(scene: dict, count: int, directory: Path) -> dict:
    import irsim

    path = directory / f"fleet_{count}.yaml"
    path.write_text(yaml.safe_dump(world_yaml(scene, count)))
    best, best_wall, collisions = math.inf, math.inf, 0
    for _ in range(scene["repeats"]):
        env = irsim.make(str(path), display=False, headless=True, log_level="ERROR")
        robots = env.robot_list
        assert len(robots) == count, f"IR-SIM made {len(robots)} robots, not {count}"
        cpu = wall = 0.0
        for _ in range(scene["steps"]):
            actions = []
            for robot in robots:
                scan = robot.get_lidar_scan()
                ranges = np.asarray(scan["ranges"], dtype=float)
                angles = scan["angle_min"] + scan["angle_increment"] * np.arange(ranges.size)
                v, w = bump_and_turn(ranges, angles)
                actions.append(np.array([[v], [w]]))
            start, start_wall = time.process_time(), time.perf_counter()
            env.step(action=actions, action_id=list(range(count)))
            cpu += time.process_time() - start
            wall += time.perf_counter() - start_wall
        best, best_wall = min(best, cpu), min(best_wall, wall)
        collisions = sum(bool(robot.collision) for robot in robots)
        env.end(0)
    return {"robots": count, "seconds": best, "wall": best_wall, "steps": scene["steps"], "collisions": collisions}


def main() -> None:
    import irsim

    scene = json.load(sys.stdin)
    with tempfile.TemporaryDirectory() as directory:
        runs = [run(scene, count, Path(directory)) for count in scene["counts"]]
    json.dump({"version": irsim.__version__, "runs": runs}, sys.stdout)


if __name__ == "__main__":
    main()
