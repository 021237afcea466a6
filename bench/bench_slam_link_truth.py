"""Each scan-match link of GraphSlam's front end against the simulator's exact truth (the mazes' links'
heading walk): what the match model alone makes, without the window's own pose errors, and against what one scan
can say at best.

Needs the recorded inputs of maze runs (`bench/bench_mapping.py --library --record --out DIR`: every scan's stamp,
odometry, ranges and true pose). Per run, the nodes are the scans GraphSlam would make nodes (update_min_d /
update_min_a of odometry); node k's scan is matched as `GraphSlam._match_local` does (the correlative match within 3
sigma of the odometry model, the posterior's mode, the point-to-line refinement, `_refined`'s mix, the fusion with
the odometry) against the window of its local_window predecessors placed at their TRUE poses (anchor: node k - 1).
A match scoring below WEAK_MATCH_SCORE (the front end's weak-match path) is left out and counted. Printed, heading
rms (deg) and position rms (mm) of node k relative to node k - 1 against the truth:

- CRB: the Cramer-Rao bound of one scan against the exact walls (each beam's range derivatives by ray casting at
  poses 1 mm / 0.006 deg apart, beams crossing an edge or beyond range_max left out, the run's LiDAR noise);
- M: the correlative match (branch and bound, bilinear refinement, posterior mode); A: the point-to-line refinement
  (`_align`) alone; R: `_refined`'s mix of the two; F: R fused with the odometry (the link's measurement);
- claimed: A's own heading sigma (its normal equations over its residuals' variance), rms;
- odometry: the odometry's own relative pose, node to node.

Options isolate the terms: `--reference clean` (the window's scans ray cast noise-free at the true poses), `--scan
clean` or `--scan SIGMA` (node k's scan ray cast at its true pose, noise-free or with that noise, seeded),
`--visible` (the window's points that node k's sensor cannot see, judged on the noise-free beams, left out: the far
face of a thin wall, a room behind a wall). Prints; asserts nothing. Usage:
.venv/bin/python bench/bench_slam_link_truth.py DIR [--runs perfect_2 ...] [--nodes 10 600] [--reference clean]
[--scan clean|SIGMA] [--visible]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np
from bench_mapping import recorded_inputs, shipped, stack_parameters  # the script's directory is on sys.path

import amr_mapping.slam as slam_module
from amr_mapping.slam_node import config_of
from amr_maps.maze_families import generate
from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import world_from_dict
from amr_simulation.config import SimulationConfig
from amr_simulation.lidar import Lidar, readings
from amr_util.geometry import Pose2D, compose, relative_pose, transform_points, wrap_angle

ESTIMATES = ("M", "A", "R", "F")


def node_rows(rows: np.ndarray, config) -> list[int]:
    """The recorded scans GraphSlam makes nodes of: update_min_d m or update_min_a rad of odometry since the last."""
    nodes = [0]
    for i in range(1, len(rows)):
        if slam_module.makes_node(relative_pose(rows[nodes[-1], 1:4], rows[i, 1:4]), config):
            nodes.append(i)
    return nodes


def bound(lidar: Lidar, pose: np.ndarray, sigma: float) -> np.ndarray:
    """The Cramer-Rao covariance (x, y in the robot's frame, heading) of one scan at pose against the exact walls."""
    base = lidar.true_ranges(Pose2D(*pose))
    c, s = math.cos(pose[2]), math.sin(pose[2])
    columns = []
    for axis, step in enumerate((1e-3, 1e-3, 1e-4)):
        local = np.zeros(3)
        local[axis] = step
        moved = np.array([c * local[0] - s * local[1], s * local[0] + c * local[1], local[2]])
        ahead = lidar.true_ranges(Pose2D(*(pose + moved)))
        behind = lidar.true_ranges(Pose2D(*(pose - moved)))
        with np.errstate(invalid="ignore"):
            columns.append((ahead - behind) / (2.0 * step))
    jacobian = np.column_stack(columns)
    smooth = (
        np.all(np.isfinite(jacobian), axis=1)
        & (base < lidar.config.range_max)
        & (np.abs(jacobian[:, :2]).max(axis=1) < 20.0)  # a beam crossing an edge: a jump, not a derivative
        & (np.abs(jacobian[:, 2]) < 50.0)
    )
    return np.linalg.inv(jacobian[smooth].T @ jacobian[smooth] / sigma**2)


def measure(path: Path, args) -> dict:
    started = time.process_time()
    data = np.load(path)
    rows, ranges, scan = data["poses"], data["ranges"], data["scan"]
    noise = float(data["lidar_noise"])
    config = config_of({**shipped("slam", "slam.yaml"), **stack_parameters("slam")})
    family, _, seed = path.name.split(".")[0].rpartition("_")
    world = world_from_dict(generate(family, int(seed)), source=f"{family} seed {seed}")
    lidar = Lidar(SimulationConfig().lidar, NumpyRayCaster(world.faces), np.random.default_rng(0))
    mount = np.array([config.lidar_x, config.lidar_y, config.lidar_yaw])
    resolution, window = config.resolution, config.local_window
    nodes = node_rows(rows, config)
    truth, odometry = rows[nodes][:, 4:7], rows[nodes][:, 1:4]
    angles = float(scan[0]) + float(scan[1]) * np.arange(ranges.shape[1])
    rng = np.random.default_rng(int(seed))

    def beams(k: int, kind: str) -> np.ndarray:
        """Node k's ranges: recorded, or ray cast at its true pose (clean, or with noise `kind` m)."""
        if kind == "recorded":
            return ranges[nodes[k]]
        exact = lidar.true_ranges(Pose2D(*truth[k]))
        return readings(exact, None if kind == "clean" else rng.normal(0.0, float(kind), len(exact)), lidar.config)

    def points(values: np.ndarray, keep: np.ndarray | None = None) -> np.ndarray:
        usable = np.isfinite(values) & (values >= float(scan[2])) & (values <= float(scan[3]))
        if keep is not None:
            usable &= keep
        return np.column_stack(
            [mount[0] + values[usable] * np.cos(angles[usable]), mount[1] + values[usable] * np.sin(angles[usable])]
        )

    errors = {name: [] for name in ESTIMATES}
    crb, claimed, odometer, weak = [], [], [], 0
    first, last = max(args.nodes[0], window), min(args.nodes[1], len(nodes))
    for k in range(first, last):
        anchor = truth[k - 1]
        sensor = np.array(compose(relative_pose(anchor, truth[k]), mount))
        exact_here = lidar.true_ranges(Pose2D(*truth[k]))
        clouds, sensors = [], []
        for member in range(k - window, k):
            placed = relative_pose(anchor, truth[member])
            sensors.append(np.array(compose(placed, mount)[:2]))
            keep = None
            if args.visible:  # judged on the noise-free beams, applied to the beams used
                values, clean_values = beams(member, args.reference), beams(member, "clean")
                both = np.isfinite(values) & (values >= float(scan[2])) & (values <= float(scan[3]))
                both &= np.isfinite(clean_values) & (clean_values <= float(scan[3]))
                clean = points(clean_values, both)
                seen = transform_points(placed, clean) - sensor[:2]
                bearing = np.arctan2(seen[:, 1], seen[:, 0]) - sensor[2]
                beam = np.round((bearing - float(scan[0])) / float(scan[1])).astype(int) % len(exact_here)
                visible = np.hypot(seen[:, 0], seen[:, 1]) <= np.minimum(exact_here[beam], float(scan[3])) + 0.01
                keep = np.zeros(len(values), bool)
                keep[np.flatnonzero(both)[visible]] = True
            clouds.append(transform_points(placed, points(beams(member, args.reference), keep)))
        prior = np.array(relative_pose(odometry[k - 1], odometry[k]))
        # as GraphSlam's window (with --facing, as it is built: the surfaces facing the prior's sensor)
        seen_from = np.vstack([np.broadcast_to(s, c.shape) for s, c in zip(sensors, clouds, strict=True)])
        viewpoint = np.array(compose(prior, mount)[:2]) if args.facing else None
        reference = slam_module._window_reference(
            np.vstack(clouds), seen_from, resolution, config.match_linear_window, viewpoint
        )
        scan_points = points(beams(k, args.scan))
        true_motion = np.array(relative_pose(anchor, truth[k]))
        information = slam_module._odometry_information(prior)
        linear, angular = slam_module._match_window(information, config)
        match = reference.matcher.match(scan_points, prior, linear, angular)
        match = slam_module._posterior_mode(
            reference.matcher, scan_points, match, prior, information, (linear, angular)
        )
        if match.score < slam_module.WEAK_MATCH_SCORE:
            weak += 1
            continue
        aligned, aligned_information = slam_module._align(reference, scan_points, match.pose, resolution)
        mixed, mixed_information, _ = slam_module._refined(reference, scan_points, match.pose, resolution)
        fused = slam_module._fused(mixed, mixed_information, prior, information)
        for name, estimate in zip(ESTIMATES, (match.pose, aligned, mixed, fused), strict=True):
            error = np.asarray(estimate, dtype=float) - true_motion
            errors[name].append([math.hypot(error[0], error[1]), wrap_angle(error[2])])
        if aligned_information is not None:
            claimed.append(np.linalg.inv(aligned_information)[2, 2])
        covariance = bound(lidar, truth[k], noise)
        crb.append([covariance[0, 0] + covariance[1, 1], covariance[2, 2]])
        odometry_error = prior - true_motion
        odometer.append([math.hypot(odometry_error[0], odometry_error[1]), wrap_angle(odometry_error[2])])
    result = {"name": path.name.split(".")[0], "noise": noise, "links": len(crb), "weak": weak}
    for name in ESTIMATES:
        values = np.array(errors[name])
        result[name] = (
            1000.0 * math.sqrt(np.mean(values[:, 0] ** 2)),
            math.degrees(math.sqrt(np.mean(values[:, 1] ** 2))),
        )
    crb = np.array(crb)
    result["CRB"] = (1000.0 * math.sqrt(np.mean(crb[:, 0])), math.degrees(math.sqrt(np.mean(crb[:, 1]))))
    result["claimed"] = math.degrees(math.sqrt(np.mean(claimed)))
    odometer = np.array(odometer)
    result["odometry"] = (
        1000.0 * math.sqrt(np.mean(odometer[:, 0] ** 2)),
        math.degrees(math.sqrt(np.mean(odometer[:, 1] ** 2))),
    )
    result["seconds"] = time.process_time() - started
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("directory", type=Path, help="recorded inputs (<run>.inputs.npz)")
    parser.add_argument("--runs", nargs="*", default=None, help="run names (perfect_2, ...); default all")
    parser.add_argument("--nodes", nargs=2, type=int, default=(10, 600), metavar=("FIRST", "LAST"))
    parser.add_argument("--reference", default="recorded", choices=("recorded", "clean"))
    parser.add_argument("--scan", default="recorded", help="recorded, clean or a noise sigma (m)")
    parser.add_argument("--visible", action="store_true", help="the window's points node k cannot see left out")
    parser.add_argument(
        "--facing", action="store_true", help="only the window's surfaces facing the prior's sensor (slam._facing)"
    )
    args = parser.parse_args()
    paths = recorded_inputs(args.directory, args.runs)
    print(
        f"reference {args.reference}, scan {args.scan}{', visible points only' if args.visible else ''}"
        f"{', facing surfaces only' if args.facing else ''}; "
        "heading rms deg / position rms mm"
    )
    print(
        f"{'run':11s} {'noise':>5s} {'links':>5s} {'weak':>4s} | {'CRB':>12s} | "
        + " | ".join(f"{name:>12s}" for name in ESTIMATES)
        + f" | {'A claimed':>9s} | {'odometry':>12s} | cpu s"
    )
    for path in paths:
        r = measure(path, args)
        cells = [f"{r[name][1]:5.3f} / {r[name][0]:4.1f}" for name in ("CRB", *ESTIMATES)]
        print(
            f"{r['name']:11s} {r['noise']:5.3f} {r['links']:5d} {r['weak']:4d} | "
            + " | ".join(cells)
            + f" | {r['claimed']:9.3f} | {r['odometry'][1]:5.3f} / {r['odometry'][0]:4.1f} | {r['seconds']:5.0f}",
            flush=True,
        )
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores)")


if __name__ == "__main__":
    main()
