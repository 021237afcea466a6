"""The pose-graph optimizer choice (docs/amr_mapping.md): amr_mapping.pose_graph (scipy sparse LM) against gtsam
4.3.0's Levenberg-Marquardt (and iSAM2 fed node by node) on Manhattan-world graphs of 1,000 and 5,000 nodes.

A graph: a walk on a 1 m grid (a step a node, turning +-90 deg at random, kept inside a square of side
sqrt(nodes) / 2 m so it crosses itself), odometry edges with noise (0.05 m, 1 deg per step), loop closures
between a node and every earlier node (more than 10 steps back) standing on the same grid point, with the same
noise; the initial guess is the odometry chained. Printed per size: each optimizer's wall time, iterations, final
chi2, and the absolute error of the result against the true poses (RMS position, m). gtsam is optional
(`pip install gtsam==4.3.0`); without it only ours runs.

Prints; asserts nothing. Usage: .venv/bin/python bench/bench_pose_graph.py [--sizes 1000 5000] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from amr_mapping.pose_graph import PoseGraph
from amr_util.geometry import compose, relative_pose

ROOT = Path(__file__).resolve().parents[1]

SIGMA = np.array([0.05, 0.05, np.radians(1.0)])


def manhattan(nodes: int, seed: int):
    """(true poses (N, 3), edges [(i, j, z, loop)]) of a grid walk with noisy measurements."""
    rng = np.random.default_rng(seed)
    half = max(3, int(np.sqrt(nodes) / 4))
    truth = np.zeros((nodes, 3))
    for k in range(1, nodes):
        x, y, theta = truth[k - 1]
        for _ in range(8):
            turn = rng.choice([0.0, np.pi / 2, -np.pi / 2], p=[0.6, 0.2, 0.2])
            heading = theta + turn
            nx, ny = round(x + np.cos(heading)), round(y + np.sin(heading))
            if abs(nx) <= half and abs(ny) <= half:
                break
        else:
            heading, nx, ny = theta + np.pi, round(x - np.cos(theta)), round(y - np.sin(theta))
        truth[k] = (nx, ny, np.arctan2(np.sin(heading), np.cos(heading)))
    edges = []
    seen: dict[tuple[int, int], list[int]] = {}
    for k in range(nodes):
        if k:
            edges.append((k - 1, k, relative_pose(truth[k - 1], truth[k]) + rng.normal(0, SIGMA), False))
        key = (int(truth[k, 0]), int(truth[k, 1]))
        for old in seen.get(key, [])[-3:]:
            if k - old > 10:
                edges.append((old, k, relative_pose(truth[old], truth[k]) + rng.normal(0, SIGMA), True))
        seen.setdefault(key, []).append(k)
    return truth, edges


def initial_guess(nodes: int, edges) -> np.ndarray:
    poses = np.zeros((nodes, 3))
    for i, j, z, loop in edges:
        if not loop:
            poses[j] = compose(poses[i], z)
    return poses


def rms(poses: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((poses[:, :2] - truth[:, :2]) ** 2, axis=1))))


def ours(truth, edges, init):
    graph = PoseGraph(loop_kernel="none")
    for pose in init:
        graph.add_node(pose)
    info = np.diag(1.0 / SIGMA**2)
    for i, j, z, loop in edges:
        graph.add_edge(i, j, z, info, loop)
    start = time.perf_counter()
    result = graph.optimize(max_iterations=50, tolerance=1e-9)
    seconds = time.perf_counter() - start
    return seconds, result.iterations, 2 * result.final_cost, rms(graph.poses, truth)


def gtsam_batch(gtsam, truth, edges, init):
    graph = gtsam.NonlinearFactorGraph()
    noise = gtsam.noiseModel.Diagonal.Sigmas(SIGMA)
    graph.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(*init[0]), gtsam.noiseModel.Diagonal.Sigmas([1e-6] * 3)))
    for i, j, z, _ in edges:
        graph.add(gtsam.BetweenFactorPose2(i, j, gtsam.Pose2(*z), noise))
    values = gtsam.Values()
    for k, pose in enumerate(init):
        values.insert(k, gtsam.Pose2(*pose))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(50)
    params.setRelativeErrorTol(1e-9)
    start = time.perf_counter()
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, values, params)
    result = optimizer.optimize()
    seconds = time.perf_counter() - start
    poses = np.array(
        [[result.atPose2(k).x(), result.atPose2(k).y(), result.atPose2(k).theta()] for k in range(len(init))]
    )
    return seconds, optimizer.iterations(), 2 * graph.error(result), rms(poses, truth)


def gtsam_isam2(gtsam, truth, edges, init):
    """Node by node as a SLAM front end would feed it: total and largest update time."""
    isam = gtsam.ISAM2(gtsam.ISAM2Params())
    noise = gtsam.noiseModel.Diagonal.Sigmas(SIGMA)
    by_node: dict[int, list] = {}
    for i, j, z, _ in edges:
        by_node.setdefault(max(i, j), []).append((i, j, z))
    estimate = np.zeros(3)
    times = []
    for k in range(len(init)):
        graph = gtsam.NonlinearFactorGraph()
        values = gtsam.Values()
        if k == 0:
            graph.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(*init[0]), gtsam.noiseModel.Diagonal.Sigmas([1e-6] * 3)))
            values.insert(0, gtsam.Pose2(*init[0]))
        for i, j, z in by_node.get(k, []):
            graph.add(gtsam.BetweenFactorPose2(i, j, gtsam.Pose2(*z), noise))
        if k:
            guess = compose(estimate, by_node[k][0][2])
            values.insert(k, gtsam.Pose2(*guess))
        start = time.perf_counter()
        isam.update(graph, values)
        result = isam.calculateEstimate()
        times.append(time.perf_counter() - start)
        p = result.atPose2(k)
        estimate = np.array([p.x(), p.y(), p.theta()])
    poses = np.array(
        [[result.atPose2(k).x(), result.atPose2(k).y(), result.atPose2(k).theta()] for k in range(len(init))]
    )
    return sum(times), max(times), rms(poses, truth)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 5000])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    try:
        import gtsam
    except ImportError:
        gtsam = None
    for nodes in args.sizes:
        truth, edges = manhattan(nodes, args.seed)
        init = initial_guess(nodes, edges)
        loops = sum(1 for e in edges if e[3])
        print(f"{nodes} nodes, {len(edges)} edges ({loops} loop closures), odometry RMS {rms(init, truth):.2f} m")
        for name, run in (("ours (scipy LM)", ours), ("gtsam LM", None)):
            if run is None:
                if gtsam is None:
                    print("  gtsam: not installed")
                    continue
                seconds, iters, chi2, error = gtsam_batch(gtsam, truth, edges, init)
            else:
                seconds, iters, chi2, error = run(truth, edges, init)
            print(f"  {name:16s} {seconds * 1000:8.1f} ms  {iters:3d} iterations  chi2 {chi2:10.1f}  RMS {error:.3f} m")
        if gtsam is not None:
            total, worst, error = gtsam_isam2(gtsam, truth, edges, init)
            print(
                f"  {'gtsam iSAM2':16s} {total * 1000:8.1f} ms in all, largest update {worst * 1000:.1f} ms, "
                f"RMS {error:.3f} m"
            )
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
