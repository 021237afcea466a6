"""Correlative scan matcher (amr_maps.scan_matcher): time per local match and per global search call, accuracy.

The map: 10 x 10 tiles of 10 m `loops` mazes (each its own seed; 0.8 m corridors, 0.05 m walls), 100 m x 100 m,
rasterized at 0.05 m (2000 x 2000 cells and a margin). Scans: 180 beams over the full turn, 3.5 m range (the
TurtleBot3 LDS), ray cast with amr_maps.raycast.NumpyRayCaster at random free poses, Gaussian range noise
(--noise, 0.02 m). Local: prior off by up to --offset m in x and y and --turn rad, window 0.5 m / 20 deg.
Global: GlobalSearch.step(--nodes) calls until done or --calls calls, the true pose's rank among the matches.

    .venv/bin/python bench/bench_scan_matcher.py [--poses 50] [--noise 0.02] [--nodes 200000]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from amr_maps.maze_families import generate
from amr_maps.rasterize import rasterize_world
from amr_maps.raycast import NumpyRayCaster
from amr_maps.scan_matcher import CorrelativeMatcher, GlobalSearch, ScoreMap
from amr_maps.world import world_from_dict

BEAMS = 180
RANGE = 3.5


def tiled_world(tiles: int = 10, tile: float = 10.0):
    walls = []
    for i in range(tiles):
        for j in range(tiles):
            maze = generate("loops", i * tiles + j, size=tile - 0.2, width=0.8, thickness=0.05, loop_fraction=0.2)
            walls += [
                [x1 + (i + 0.5) * tile, y1 + (j + 0.5) * tile, x2 + (i + 0.5) * tile, y2 + (j + 0.5) * tile]
                for x1, y1, x2, y2 in maze["walls"]
            ]
    start = generate("loops", 0, size=tile - 0.2, width=0.8, thickness=0.05, loop_fraction=0.2)["start"]
    return world_from_dict(
        {"wall_thickness": 0.05, "walls": walls, "start": [start[0] + 0.5 * tile, start[1] + 0.5 * tile, start[2]]}
    )


def scan_points(caster: NumpyRayCaster, pose: np.ndarray, rng: np.random.Generator, noise: float) -> np.ndarray:
    increment = 2.0 * math.pi / BEAMS
    angles = -math.pi + increment * np.arange(BEAMS)
    ranges = caster.cast(pose[0], pose[1], pose[2] - math.pi, increment, BEAMS, RANGE)
    ranges = ranges + rng.normal(0.0, noise, BEAMS)
    keep = np.isfinite(ranges) & (ranges < RANGE)
    return np.column_stack([ranges[keep] * np.cos(angles[keep]), ranges[keep] * np.sin(angles[keep])])


def free_poses(grid, world, rng: np.random.Generator, count: int) -> np.ndarray:
    rows, cols = np.nonzero(grid.free())
    poses = []
    while len(poses) < count:
        k = int(rng.integers(len(rows)))
        x, y = grid.cell_to_world(rows[k], cols[k])
        x, y = float(x) + rng.uniform(-0.025, 0.025), float(y) + rng.uniform(-0.025, 0.025)
        if world.clearance(np.array([[x, y]]))[0] > 0.15:
            poses.append((x, y, rng.uniform(-math.pi, math.pi)))
    return np.array(poses)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=50)
    parser.add_argument("--noise", type=float, default=0.02)
    parser.add_argument("--offset", type=float, default=0.3)
    parser.add_argument("--turn", type=float, default=math.radians(15))
    parser.add_argument("--nodes", type=int, default=200_000)
    parser.add_argument("--calls", type=int, default=100)
    parser.add_argument("--global-poses", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)

    t = time.perf_counter()
    world = tiled_world()
    grid = rasterize_world(world, 0.05)
    t_map = time.perf_counter() - t
    t = time.perf_counter()
    score_map = ScoreMap.from_occupancy(grid)
    matcher = CorrelativeMatcher(score_map)
    t_matcher = time.perf_counter() - t
    print(
        f"map {grid.width} x {grid.height} cells at {grid.resolution} m ({t_map:.1f} s to build); score map and "
        f"pyramid of {matcher.levels} levels {t_matcher:.2f} s, {matcher.pyramid.nbytes / 1e6:.0f} MB"
    )
    caster = NumpyRayCaster(world.faces)
    poses = free_poses(grid, world, rng, args.poses)
    scans = [scan_points(caster, pose, rng, args.noise) for pose in poses]
    matcher.match(scans[0], poses[0], 0.5, math.radians(20))  # compile / load the kernels

    times, errors, turns, nodes = [], [], [], []
    for pose, points in zip(poses, scans, strict=True):
        prior = pose + np.array(
            [
                rng.uniform(-args.offset, args.offset),
                rng.uniform(-args.offset, args.offset),
                rng.uniform(-args.turn, args.turn),
            ]
        )
        t = time.perf_counter()
        found = matcher.match(points, prior, 0.5, math.radians(20))
        times.append(time.perf_counter() - t)
        errors.append(math.hypot(*(found.pose[:2] - pose[:2])))
        turns.append(abs(math.remainder(found.pose[2] - pose[2], 2.0 * math.pi)))
        nodes.append(found.nodes)
    times_ms = 1e3 * np.array(times)
    errors_cm = 100.0 * np.array(errors)
    print(
        f"local match ({args.poses} scans, {np.mean([len(s) for s in scans]):.0f} points, noise {args.noise} m, "
        f"prior off by <= {args.offset} m / {math.degrees(args.turn):.0f} deg, window 0.5 m / 20 deg): "
        f"{np.median(times_ms):.2f} ms median, {times_ms.max():.2f} ms max, {np.median(nodes):.0f} nodes; "
        f"position error {np.median(errors_cm):.2f} cm median, {errors_cm.max():.2f} cm max; heading error "
        f"{np.degrees(np.median(turns)):.2f} deg median, {np.degrees(np.max(turns)):.2f} deg max"
    )

    for pose, points in zip(poses[: args.global_poses], scans[: args.global_poses], strict=True):
        t = time.perf_counter()
        search = GlobalSearch(matcher, points)
        t_setup = time.perf_counter() - t
        call_times = []
        for _ in range(args.calls):
            t = time.perf_counter()
            matches = search.step(args.nodes)
            call_times.append(time.perf_counter() - t)
            if search.done:
                break
        distances = [math.hypot(*(m.pose[:2] - pose[:2])) for m in matches]
        rank = next((k for k, d in enumerate(distances) if d < 0.3), None)
        call_ms = 1e3 * np.array(call_times)
        print(
            f"global search: setup {1e3 * t_setup:.0f} ms, {len(call_ms)} calls of {args.nodes} nodes "
            f"({'done' if search.done else 'not done'}), {np.median(call_ms):.0f} ms median {call_ms.max():.0f} "
            f"ms max per call; true pose rank {rank} (score {matches[0].score:.3f} best"
            + (f", {matches[rank].score:.3f} true" if rank is not None else "")
            + ")"
        )


if __name__ == "__main__":
    main()
