"""GraphSlam on real robots' laser logs (docs/amr_mapping.md): the four CARMEN logs of ../shared/data/carmen
(intel, aces, fhw, orebro; their SLAM-corrected poses are the reference), fed scan by scan with odometry
synthesized from the corrected poses (amr_datasets.odometry: 5 % noise, 1 % scale error, 0.5 deg/m heading bias,
seeded).

Printed per log: scans, nodes, loop closures, the relative displacement error of Kümmerle et al. 2009 (pairs
1..10 m of path apart: mean translational m and rotational deg), the absolute trajectory error after a rigid
alignment (RMS, m), the odometry's own figures for comparison, the time per scan (mean, p95, max, ms) and the
total time against the log's duration (speed factor; orebro has no stamps); the CPU time of each scan's update
(its thread's: what a loaded machine does not inflate as much as the wall clock) p95 and max, and the scan
with the max (the kernels are loaded before timing: warm_up). The estimate compared is the final one: each
scan's pose is its node's optimized pose composed with the odometry since that node. loops: the closures in
the final graph (those removed after an optimization not counted).
Goals (the issue): relative error <= 5 cm and <= 1 deg, ATE <= 0.2 m, >= 10x faster than recorded, no scan
above 200 ms.

Prints; asserts nothing. Usage: .venv/bin/python bench/bench_slam_logs.py [--data DIR] [--logs intel ...]
[--seeds 0 (several: a summary across them)] [--reverse] [--stride N]
[--save DIR (maps and poses of each log; DIR/seedN with several)] [--slam KEY=VALUE ... (SlamConfig fields)]
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from amr_datasets.carmen import LOG_MOUNT, log_name, played_backwards, read_carmen, thinned
from amr_datasets.odometry import synthesize_odometry
from amr_mapping.errors import MappingError
from amr_mapping.slam import GraphSlam, SlamConfig
from amr_mapping.trajectory_error import absolute_error, relative_error
from amr_util.geometry import compose, relative_pose

ROOT = Path(__file__).resolve().parents[1]

DATA = Path(__file__).resolve().parents[2] / "shared/data/carmen"


def scan_estimates(poses: np.ndarray, node_of: list[int], odometry: np.ndarray) -> np.ndarray:
    """(N, 3) each scan's pose: the optimized pose of its node (node_of[k], the newest node at scan k) and the
    odometry since that node's scan."""
    node_odometry = {}
    for k, n in enumerate(node_of):
        node_odometry.setdefault(n, odometry[k])
    return np.array([compose(poses[n], relative_pose(node_odometry[n], odometry[k])) for k, n in enumerate(node_of)])


def run_log(
    path: Path, seed: int, config: SlamConfig, save: Path | None, reverse: bool = False, stride: int = 1
) -> dict:
    """One log through GraphSlam: the figures of the module docstring."""
    log = thinned(read_carmen(path), stride)
    log = played_backwards(log) if reverse else log
    reference = log.poses()
    odometry = synthesize_odometry(reference, seed=seed)
    slam = GraphSlam(config)
    times, cpu, node_of, closures, events = [], [], [], 0, 0
    node = -1
    for k, (item, odom) in enumerate(zip(log.scans, odometry, strict=True)):
        stamp = int(round(item.stamp * 1e9))
        cpu_start = time.thread_time()
        try:
            update = slam.add(stamp, odom, item.scan)
        except MappingError as error:
            print(f"  scan {k}: {error}")
            times.append(0.0)
            cpu.append(time.thread_time() - cpu_start)
            node_of.append(node)
            continue
        times.append(update.seconds)
        cpu.append(time.thread_time() - cpu_start)
        if update.node_added:
            node = update.node
        node_of.append(node)
        closures += len(update.loop_closures)
        events += sum(1 for e in update.events if "odometry alone" in e)
    slam.optimize()  # the closures whose optimization was deferred
    poses, _, _ = slam.graph()
    estimate = scan_estimates(poses, node_of, odometry)
    rel = relative_error(estimate, reference)
    ate = absolute_error(estimate, reference)
    rel_odom = relative_error(odometry, reference)
    ate_odom = absolute_error(odometry, reference)
    times_ms = np.array(times) * 1000.0
    cpu_ms = np.array(cpu) * 1000.0
    total = float(np.sum(times))
    duration = float(log.stamps()[-1] - log.stamps()[0]) if log.has_stamps else None
    if save is not None:
        save.mkdir(parents=True, exist_ok=True)
        map_start = time.perf_counter()
        slam.save(save / log_name(path))
        print(f"  map saved in {time.perf_counter() - map_start:.2f} s")
    return {
        "name": log_name(path),
        "scans": len(log),
        "nodes": len(poses),
        "closures": int(slam.graph()[2].sum()),
        "odometry_only": events,
        "rel_t": rel.translation,
        "rel_r": rel.rotation_deg,
        "ate": ate.rmse,
        "odom_rel_t": rel_odom.translation,
        "odom_rel_r": rel_odom.rotation_deg,
        "odom_ate": ate_odom.rmse,
        "mean": times_ms.mean(),
        "p95": np.percentile(times_ms, 95),
        "max": times_ms.max(),
        "cpu_p95": np.percentile(cpu_ms, 95),
        "cpu_max": cpu_ms.max(),
        "cpu_max_scan": int(np.argmax(cpu_ms)),
        "dropped": slam.dropped_closures,
        "total": total,
        "duration": duration,
    }


def print_summary(rows: list[dict], seeds: int) -> None:
    """Per log, across the odometry seeds: the relative error's mean (m, deg) and worst, the ATE's median and worst,
    and how many seeds meet the goals (rel <= 5 cm and 1 deg, ATE <= 0.2 m)."""
    print(f"across {seeds} seeds: rel m mean / max, rel deg mean / max, ATE m median / max; seeds meeting ATE, rel")
    for name in dict.fromkeys(row["name"] for row in rows):
        mine = [row for row in rows if row["name"] == name]
        rel_t, rel_r, ate = (np.array([row[key] for row in mine]) for key in ("rel_t", "rel_r", "ate"))
        print(
            f"{name:8s} {rel_t.mean():6.3f} / {rel_t.max():6.3f}  {rel_r.mean():5.2f} / {rel_r.max():5.2f}  "
            f"{np.median(ate):6.3f} / {ate.max():6.3f}  {int(np.sum(ate <= 0.2)):3d} of {len(mine)}"
            f"  {int(np.sum((rel_t <= 0.05) & (rel_r <= 1.0))):3d} of {len(mine)}"
        )


def warm_up(path: Path, config: SlamConfig, scans: int = 30) -> None:
    """The first scans of a log through a GraphSlam, untimed: the process's first update loads the compiled
    kernels (numba's cache: 0.2-0.25 s once per process, at load 6), which is start-up, not a scan's cost."""
    log = read_carmen(path)
    slam = GraphSlam(config)
    for item, odom in zip(log.scans[:scans], synthesize_odometry(log.poses()[:scans], seed=0), strict=True):
        try:
            slam.add(int(round(item.stamp * 1e9)), odom, item.scan)
        except MappingError:
            pass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--logs", nargs="*", default=None, help="log names (intel, aces, ...); default all")
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=[0], help="odometry noise seeds; several: a summary across them"
    )
    parser.add_argument("--save", type=Path, default=None)
    parser.add_argument("--reverse", action="store_true", help="each log's scans played backwards (stamps mirrored)")
    parser.add_argument("--stride", type=int, default=1, help="every stride-th scan only (keyframes farther apart)")
    parser.add_argument(
        "--slam", nargs="*", default=[], metavar="KEY=VALUE", help="SlamConfig fields over the defaults"
    )
    args = parser.parse_args()
    paths = sorted(args.data.glob("*.log*"))
    if args.logs:
        paths = [p for p in paths if log_name(p) in args.logs]
    if not paths:
        sys.exit(f"no CARMEN logs in {args.data}")
    overrides = {}
    for item in args.slam:
        key, _, value = item.partition("=")
        overrides[key] = yaml.safe_load(value)
    config = SlamConfig(**{**LOG_MOUNT, **overrides})
    print(f"config: {config}")
    warm_up(paths[0], config)
    gc.collect()
    header = (
        f"{'log':8s} {'scans':>5s} {'nodes':>5s} {'loops':>5s} {'odo':>4s} | {'rel m':>6s} {'rel deg':>7s} "
        f"{'ATE m':>6s} | odometry: {'rel m':>6s} {'rel deg':>7s} {'ATE m':>6s} | "
        f"{'mean':>5s} {'p95':>5s} {'max':>5s} ms | cpu {'p95':>5s} {'max':>5s} ms @scan | speed"
    )
    rows = []
    for seed, path in ((seed, path) for seed in args.seeds for path in paths):
        save = args.save / f"seed{seed}" if args.save is not None and len(args.seeds) > 1 else args.save
        result = run_log(path, seed, config, save, args.reverse, args.stride)
        rows.append(result)
        if len(args.seeds) > 1:
            print(f"seed {seed} ", end="")
        speed = f"{result['duration'] / result['total']:.0f}x" if result["duration"] else "n/a (no stamps)"
        print(
            f"{result['name']:8s} {result['scans']:5d} {result['nodes']:5d} {result['closures']:5d} "
            f"{result['odometry_only']:4d} | {result['rel_t']:6.3f} {result['rel_r']:7.2f} {result['ate']:6.3f} | "
            f"          {result['odom_rel_t']:6.3f} {result['odom_rel_r']:7.2f} {result['odom_ate']:6.3f} | "
            f"{result['mean']:5.1f} {result['p95']:5.1f} {result['max']:5.1f}    | "
            f"    {result['cpu_p95']:5.1f} {result['cpu_max']:5.1f} @{result['cpu_max_scan']:<4d} | {speed}"
            f" ({result['total']:.1f} s)",
            flush=True,
        )
    print(header)
    if len(args.seeds) > 1:
        print_summary(rows, len(args.seeds))
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores)")


if __name__ == "__main__":
    main()
