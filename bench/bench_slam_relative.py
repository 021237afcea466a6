"""Where GraphSlam's relative translational error on the CARMEN logs comes from (docs/amr_mapping.md, Figures; the
decision record's "relative error" round): the mean over the pairs 1-10 m of path apart (Kümmerle et al. 2009, as
bench_slam_logs.py, the same estimate: each scan's pose its node's optimized pose and the odometry since) split
into the terms the pair's error is made of.

Per log (odometry synthesized as in bench_slam_logs.py, seed 0; --slam KEY=VALUE over the defaults):

- the pair's error (the reference's frame at the pair's start) along its displacement (a length: scale, a match
  short or long along a corridor) and across it; across = length x the chord's direction error, which is the start
  pose's heading error against the trajectory (node heading noise: the start's heading off its neighbours' within
  +-HEADING_SPAN m of path) plus the trajectory's own bend over the pair (the chord's direction against the
  neighbours' heading: drift);
- "explained": the mean translational error with one term taken out (the along part set to 0, the start's heading
  spike removed, the bend removed) against the mean as it is;
- the error against the pair's length (1-2, 2-4, 4-7, 7-10 m) and against where along the route the pair lies
  (tenths of the scans; the share of pairs whose nodes have a closure within 5 nodes);
- the nodes' heading error against the reference (the ATE alignment's rotation taken out): its spikes (a node off
  its neighbours) and its smooth part's change between closures;
- --front-end: the same log with no loop closure (loop_search_radius 0.001): the metric on pairs 1-2 m (the front
  end alone, where the reference's own noise floor weighs most) and 1-10 m.

The runs are cached (--cache DIR, one .npz per log, seed and configuration: not per code, so a new --cache after a
change) so the analysis can be redone without them.
Prints; asserts nothing. Usage: .venv/bin/python bench/bench_slam_relative.py [--logs aces ...] [--front-end]
[--cache /tmp/slam_relative] [--slam KEY=VALUE ...] [--reverse]
"""

from __future__ import annotations

import argparse
import hashlib
import math
import os
import sys
from pathlib import Path

import numpy as np
import yaml
from bench_slam_logs import DATA, scan_estimates  # the script's directory is on sys.path

from amr_datasets.carmen import LOG_MOUNT, played_backwards, read_carmen
from amr_datasets.odometry import synthesize_odometry
from amr_mapping.errors import MappingError
from amr_mapping.slam import GraphSlam, SlamConfig
from amr_mapping.trajectory_error import (
    absolute_error,
    relative_error,
    relative_motions,
    relative_pairs,
)
from amr_util.geometry import wrap_angle

HEADING_SPAN = 1.0
"""m of path either side of a scan over which its neighbours' heading error is its trajectory's heading."""
BINS = (1.0, 2.0, 4.0, 7.0, 10.0)


def run(path: Path, seed: int, config: SlamConfig, cache: Path, reverse: bool = False) -> dict:
    """The log through GraphSlam (or the cache): per-scan estimate, reference, node of each scan, the graph."""
    key = hashlib.sha1(f"{path.name}{seed}{config}{'reverse' if reverse else ''}".encode()).hexdigest()[:12]
    file = cache / f"{path.name.split('-')[0]}_{key}.npz"
    if file.exists():
        return dict(np.load(file))
    log = played_backwards(read_carmen(path)) if reverse else read_carmen(path)
    reference = log.poses()
    odometry = synthesize_odometry(reference, seed=seed)
    slam = GraphSlam(config)
    node_of, node = [], -1
    for item, odom in zip(log.scans, odometry, strict=True):
        try:
            update = slam.add(int(round(item.stamp * 1e9)), odom, item.scan)
        except MappingError:
            node_of.append(node)
            continue
        if update.node_added:
            node = update.node
        node_of.append(node)
    slam.optimize()
    poses, edges, loop = slam.graph()
    result = {
        "estimate": scan_estimates(poses, node_of, odometry),
        "reference": reference,
        "node_of": np.array(node_of),
        "edges": edges,
        "loop": loop,
        "poses": poses,
    }
    cache.mkdir(parents=True, exist_ok=True)
    np.savez(file, **result)
    return result


def _rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else float("nan")


def decompose(name: str, data: dict) -> None:
    estimate, reference, node_of = data["estimate"], data["reference"], data["node_of"]
    rel = relative_error(estimate, reference)
    ate = absolute_error(estimate, reference)
    alpha = ate.alignment[2]
    i, j = relative_pairs(reference, 1.0, 10.0)
    d_est, d_ref = relative_motions(estimate, i, j), relative_motions(reference, i, j)
    dx, dy = d_est[:, 0] - d_ref[:, 0], d_est[:, 1] - d_ref[:, 1]
    # the error in the reference's frame at i (the metric's |e|); split along / across the displacement
    length = np.hypot(d_ref[:, 0], d_ref[:, 1])
    ux, uy = d_ref[:, 0] / length, d_ref[:, 1] / length
    along = dx * ux + dy * uy
    across = -dx * uy + dy * ux
    translation = np.hypot(along, across)
    # each scan's heading error (the alignment's rotation out) and its trajectory's (neighbours within HEADING_SPAN)
    heading = wrap_angle(estimate[:, 2] + alpha - reference[:, 2])
    travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(reference[:, :2], axis=0).T))])
    lo = np.searchsorted(travelled, travelled - HEADING_SPAN, side="left")
    hi = np.searchsorted(travelled, travelled + HEADING_SPAN, side="right")
    unwrapped = np.unwrap(heading)
    cum = np.concatenate([[0.0], np.cumsum(unwrapped)])
    smooth = (cum[hi] - cum[lo]) / np.maximum(hi - lo, 1)
    spike = wrap_angle(unwrapped - smooth)
    # the chord's direction error (world, aligned) against the start's heading error: across ~ length x (chord - start)
    chord_est = np.arctan2(*(estimate[j, 1::-1] - estimate[i, 1::-1]).T) + alpha
    chord_ref = np.arctan2(*(reference[j, 1::-1] - reference[i, 1::-1]).T)
    chord = wrap_angle(chord_est - chord_ref)
    predicted = length * wrap_angle(chord - heading[i])
    bend = length * wrap_angle(chord - smooth[i])
    start = -length * spike[i]
    mean = translation.mean()
    print(
        f"{name}: {len(i)} pairs; rel. translation {rel.translation:.4f} m (rotation {rel.rotation_deg:.2f} deg), "
        f"ATE {ate.rmse:.3f}; along rms {100 * _rms(along):.1f} cm, across {100 * _rms(across):.1f} "
        f"(length x chord angle: {100 * _rms(predicted):.1f}, of it the start's heading spike {100 * _rms(start):.1f}, "
        f"the bend {100 * _rms(bend):.1f})"
    )
    without = {
        "along": np.abs(across),
        "across": np.abs(along),
        "the start's heading spike": np.hypot(along, across - start),
        "the bend": np.hypot(along, across - bend),
        "spike and bend": np.hypot(along, across - start - bend),
    }
    print(
        "  mean without: "
        + ", ".join(f"{k} {100 * v.mean():.1f} cm ({100 * (1 - v.mean() / mean):.0f} %)" for k, v in without.items())
        + f" (with all: {100 * mean:.1f})"
    )
    # scale: the pairs' length error per metre, its mean (a bias: short or long) and spread
    print(
        f"  along per metre of pair: mean {100 * np.mean(along / length):+.2f} %, "
        f"rms {100 * _rms(along / length):.2f} %; "
        f"the heading spike's rms {math.degrees(_rms(spike)):.2f} deg over the scans, the rotation error of the "
        f"pairs {math.degrees(_rms(wrap_angle(d_est[:, 2] - d_ref[:, 2]))):.2f} deg rms"
    )
    parts = []
    for a, b in zip(BINS[:-1], BINS[1:], strict=True):
        k = (length >= a) & (length < b) if b < BINS[-1] else (length >= a)
        if k.any():
            parts.append(
                f"{a:.0f}-{b:.0f} m ({int(k.sum())}): {100 * translation[k].mean():.1f} cm, along "
                f"{100 * np.abs(along[k]).mean():.1f}, across {100 * np.abs(across[k]).mean():.1f}, "
                f"rot {np.degrees(np.abs(wrap_angle(d_est[k, 2] - d_ref[k, 2]))).mean():.2f} deg"
            )
    print("  by the displacement's length: " + "; ".join(parts))
    # along the route: tenths of the scans by the pair's start; pairs with a closure's node within 5 nodes
    loop_nodes = np.unique(data["edges"][data["loop"]].ravel()) if data["loop"].any() else np.array([], int)
    near = np.zeros(len(data["poses"]), dtype=bool)
    for n in loop_nodes:
        near[max(0, n - 5) : n + 6] = True
    closed = near[node_of[i]] | near[node_of[j]]
    tenths = np.minimum((10 * i) // len(reference), 9)
    row = " ".join(f"{100 * translation[tenths == t].mean():4.1f}" for t in range(10) if (tenths == t).any())
    print(f"  by tenth of the route (cm): {row}")
    parts = [
        f"{label} {int(k.sum())}, {100 * translation[k].mean():.1f} cm"
        for label, k in (("with", closed), ("without", ~closed))
        if k.any()
    ]
    print("  pairs with or without a closure's node within 5 nodes of either end: " + "; ".join(parts))
    # the worst pairs' starts: how concentrated the error is
    by_start = np.bincount(i, weights=translation, minlength=len(reference))
    order = np.argsort(-by_start)
    share = by_start[order[: len(reference) // 20]].sum() / by_start.sum()
    print(
        f"  the 5 % of scans whose pairs start there carrying most: {share:.0%} of the sum; worst starts: "
        + ", ".join(
            f"{k} ({math.degrees(spike[k]):+.1f} deg spike, {100 * translation[i == k].mean():.0f} cm)"
            for k in order[:6]
        )
    )
    # the nodes' heading error: smooth part's change between closures
    nodes = np.array([np.flatnonzero(node_of == n)[0] for n in range(len(data["poses"])) if (node_of == n).any()])
    if len(loop_nodes):
        walks = []
        boundaries = np.flatnonzero(near[node_of[nodes]])
        for a, b in zip(boundaries[:-1], boundaries[1:], strict=True):
            if b - a > 10:
                walks.append(abs(math.degrees(smooth[nodes[b]] - smooth[nodes[a]])))
        if walks:
            print(
                f"  smooth heading change over {len(walks)} stretches of > 10 nodes without a closure: median "
                f"{np.median(walks):.2f}, max {np.max(walks):.2f} deg"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--logs", nargs="*", default=["intel", "fhw", "aces", "orebro"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cache", type=Path, default=Path("/tmp/slam_relative"))
    parser.add_argument("--front-end", action="store_true", help="also the log without closures")
    parser.add_argument("--slam", nargs="*", default=[], metavar="KEY=VALUE")
    parser.add_argument("--reverse", action="store_true", help="each log played backwards (bench_slam_logs.py's)")
    args = parser.parse_args()
    overrides = {k: yaml.safe_load(v) for k, _, v in (item.partition("=") for item in args.slam)}
    for name in args.logs:
        path = next(iter(sorted(args.data.glob(f"{name}*"))), None)
        if path is None:
            sys.exit(f"no log {name} in {args.data}")
        config = SlamConfig(**{**LOG_MOUNT, **overrides})
        data = run(path, args.seed, config, args.cache, args.reverse)
        decompose(name, data)
        if args.front_end:
            no_closures = SlamConfig(**{**LOG_MOUNT, **overrides, "loop_search_radius": 0.001})
            alone = run(path, args.seed, no_closures, args.cache, args.reverse)
            for label, d in (("full", data), ("front end alone", alone)):
                short = relative_error(d["estimate"], d["reference"], 1.0, 2.0)
                whole = relative_error(d["estimate"], d["reference"])
                print(
                    f"  {label}: pairs 1-2 m {100 * short.translation:.1f} cm / {short.rotation_deg:.2f} deg, "
                    f"1-10 m {100 * whole.translation:.1f} cm / {whole.rotation_deg:.2f} deg"
                )
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores)")


if __name__ == "__main__":
    main()
