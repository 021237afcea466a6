"""GraphSlam's front end along generated corridors (the decision record's surfaces round,
docs/decisions/2026-11-29-slam-front-end-and-closures.md): the error of each step (node to node) against the truth,
where the walls say little along the way.

Worlds: a corridor 2.4 m wide and 24 m long, closed at both ends, with nothing along it (`bare`), with a room beside
it through two doorways (`door`), or with boxes along its walls (`boxes`). The robot drives its centre line (a 10 cm
weave) in 0.9 m keyframes, one way or the other, facing +x along the weave (forwards or reversing, as a
differential drive can: before 2026-12-03 it drove sideways, which the odometry motion model reads as quarter turns),
its 180-degree laser (181 beams, 8 m, 1 cm noise) mounted at a heading of its own (lidar_yaw): 0 faces +x; the
odometry 3 % long with 1 cm and 0.3 deg of noise a step. No loop closure is searched
(the front end alone). Per world, heading and direction: the steps' position error over the seeds, mean / p90 / max.

Prints; asserts nothing. Usage: .venv/bin/python bench/bench_slam_corridors.py [--worlds bare door boxes]
[--headings 0 45 90 180 -135] [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from amr_mapping.slam import GraphSlam, SlamConfig
from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import world_from_dict
from amr_util.geometry import compose, relative_pose
from amr_util.scan import ScanData

BEAMS = 181
FOV = math.pi
MAX_RANGE = 8.0
STEP = 0.9


def corridor(kind: str) -> NumpyRayCaster:
    walls = [[0, 0, 24, 0], [24, 0, 24, 2.4], [24, 2.4, 0, 2.4], [0, 2.4, 0, 0]]
    boxes = []
    if kind == "door":
        walls = [[0, 0, 24, 0], [24, 0, 24, 2.4], [24, 2.4, 16, 2.4], [15, 2.4, 10, 2.4], [9, 2.4, 0, 2.4]]
        walls += [[0, 2.4, 0, 0], [8, 2.4, 8, 5.4], [8, 5.4, 17, 5.4], [17, 5.4, 17, 2.4]]
    elif kind == "boxes":
        boxes = [[x, 0, x + 0.4, 0.3] for x in (3.0, 8.5, 13.0, 19.0)]
        boxes += [[x, 2.1, x + 0.3, 2.4] for x in (5.5, 11.0, 16.5)]
    elif kind != "bare":
        raise SystemExit(f"unknown world {kind!r}: bare, door or boxes")
    world = world_from_dict({"walls": walls, "wall_thickness": 0.1, "start": [2, 1.2, 0], "boxes": boxes})
    return NumpyRayCaster(world.faces)


def step_errors(caster: NumpyRayCaster, heading: float, direction: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    start = 2.0 if direction > 0 else 22.0
    x = np.array([start + direction * STEP * k for k in range(int(19 / STEP))])
    y = 1.2 + 0.1 * np.sin(np.arange(len(x)) + seed)
    # a differential-drive robot facing +x along its weave (forwards one way, reversing the other: the motion model
    # reads neither as a turn), its laser mounted at `heading` (lidar_yaw): it cannot drive sideways
    facing = np.arctan(np.gradient(y) / np.gradient(x))
    truth = np.column_stack([x, y, facing])
    odometry = [np.zeros(3)]
    for k in range(1, len(truth)):
        step = np.array(relative_pose(truth[k - 1], truth[k]))
        step[:2] *= 1.03
        step += rng.normal(0.0, [0.01, 0.01, 0.005])
        odometry.append(np.array(compose(odometry[-1], step)))
    slam = GraphSlam(SlamConfig(max_range_used=MAX_RANGE, lidar_x=0.0, lidar_yaw=heading, loop_min_travel=1000.0))
    increment = FOV / (BEAMS - 1)
    for k, (pose, odom) in enumerate(zip(truth, odometry, strict=True)):
        ranges = caster.cast(pose[0], pose[1], pose[2] + heading - FOV / 2, increment, BEAMS, MAX_RANGE)
        scan = ScanData(ranges + rng.normal(0.0, 0.01, BEAMS), -FOV / 2, increment, 0.1, MAX_RANGE + 1.0)
        slam.add(k * 1_000_000_000, odom, scan)
    poses = slam.graph()[0]
    errors = []
    for k in range(1, len(truth)):
        estimated, true = relative_pose(poses[k - 1], poses[k]), relative_pose(truth[k - 1], truth[k])
        errors.append(math.hypot(estimated[0] - true[0], estimated[1] - true[1]))
    return np.array(errors)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", nargs="*", default=["bare", "door", "boxes"])
    parser.add_argument("--headings", nargs="*", type=float, default=[0.0, 45.0, 90.0, 180.0, -135.0])
    parser.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2])
    args = parser.parse_args()
    print("world  heading  way | step error m: mean   p90    max")
    for kind in args.worlds:
        caster = corridor(kind)
        for heading in args.headings:
            for direction in (1, -1):
                errors = np.concatenate(
                    [step_errors(caster, math.radians(heading), direction, seed) for seed in args.seeds]
                )
                print(
                    f"{kind:6s} {heading:7.0f}  {'+x' if direction > 0 else '-x'}  |"
                    f"              {errors.mean():.3f}  {np.percentile(errors, 90):.3f}  {errors.max():.3f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
