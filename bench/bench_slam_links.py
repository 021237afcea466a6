"""Where GraphSlam's relative error on the CARMEN logs comes from (docs/amr_mapping.md, Figures): its links and
nodes against the corrected poses, and the corrected poses' own noise (what a perfect method would score).

For each log (odometry synthesized as in bench_slam_logs.py, seed 0, default SlamConfig with the LiDAR at the log's
poses, LOG_MOUNT):

- links: each sequential edge's measurement (the front end's) and the optimized poses' increment against the
  reference's: translation and heading error, median / mean / p90, and the share of the heading error in the
  worst 10 % of the links; the heading error growing with the lag (1 and 8 nodes): per-pose noise stays, drift
  grows;
- chi-square of the graph's edges at the reference poses (scan matches, closures; 3 on average if each edge's
  information is its error's), and with the reference's own noise per pose (--reference-sigma: aces' measured by
  --reference, 1.5 cm and 0.26 deg) added to each edge's covariance;
- nodes: how many nodes' headings are more than 1.5 deg off their two neighbours' (estimate against reference),
  the worst listed (a single match off, put back by the next: every pair starting there is off by its heading
  times the pair's length).
- along and across: the nodes' pairs 1-10 m of path apart, their error split along the pair's displacement (a
  length: corridors) and across it (a heading), rms; the front end's links' along-track error (rms, median) and the
  share of its square in the links more than 6 cm off (single matches a bump along a corridor, put back by the next);
- --oracle-window: each node's scan matched by the front end's correlative matcher (its window: WINDOW_SIGMAS of the
  odometry model) against the likelihood field of its local_window predecessors at their corrected poses, as the
  front end would with a perfect window: along-track and heading error of that match against the corrected poses.
- --reference: each scan (every --every-th) matched by the front end's correlative matcher at its corrected pose
  against the likelihood field of the other scans within 10 m at theirs, once those before it (more than --skip
  scans away) and once those after: the covariance of the two corrections is the reference's own error per pose
  (rms per component), the rest each side's matcher noise; then the relative error that a trajectory exact but
  for per-pose noise of that size (and of 2 cm, 0.3 deg) scores against the reference.

Prints; asserts nothing. Usage: .venv/bin/python bench/bench_slam_links.py [--logs aces ...] [--reference]
[--oracle-window] [--every 2] [--skip 1]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

import numpy as np

from amr_datasets.carmen import LOG_MOUNT, read_carmen
from amr_datasets.odometry import synthesize_odometry
from amr_mapping.errors import MappingError
from amr_mapping.slam import (
    LIKELIHOOD_PAD,
    LIKELIHOOD_SIGMA_CELLS,
    GraphSlam,
    SlamConfig,
    _beams,
    _match_window,
    _odometry_information,
    _window_reference,
)
from amr_mapping.trajectory_error import relative_error, relative_motions, relative_pairs
from amr_maps.scan_matcher import CorrelativeMatcher, ScoreMap
from amr_util.geometry import compose, relative_pose, transform_points, wrap_angle

DATA = Path(__file__).resolve().parents[2] / "shared/data/carmen"


def _stats(values: np.ndarray, scale: float) -> str:
    values = np.abs(values) * scale
    return f"{np.median(values):.2f} / {values.mean():.2f} / {np.percentile(values, 90):.2f}"


def mapped(log, seed: int, config: SlamConfig):
    """The log through GraphSlam with synthesized odometry: (slam, each node's scan index, reference, odometry)."""
    reference = log.poses()
    odometry = synthesize_odometry(reference, seed=seed)
    slam = GraphSlam(config)
    scan_of: list[int] = []
    for k, (item, odom) in enumerate(zip(log.scans, odometry, strict=True)):
        try:
            update = slam.add(int(round(item.stamp * 1e9)), odom, item.scan)
        except MappingError:
            continue
        if update.node_added:
            scan_of.append(k)
    return slam, scan_of, reference, odometry


def links(name: str, log, seed: int, reference_sigma: tuple[float, float] = (0.015, 0.26)) -> None:
    slam, scan_of, reference, odometry = mapped(log, seed, SlamConfig(**LOG_MOUNT))
    slam.optimize()
    poses, edges, loop = slam.graph()
    scans = np.array(scan_of)
    sequential = np.flatnonzero(~loop)
    i, j = edges[sequential, 0], edges[sequential, 1]
    truth = relative_motions(reference, scans[i], scans[j])
    measured = slam._graph._z[sequential]  # the edges' measurements: the front end's (a diagnostic reads them)
    optimized = relative_motions(poses, i, j)
    print(
        f"{name}: {len(poses)} nodes, {int(loop.sum())} closures; link error: translation cm, heading deg "
        "(median / mean / p90)"
    )
    for label, estimate in (("front end", measured), ("optimized", optimized)):
        error = estimate - truth
        heading = np.degrees(np.abs(wrap_angle(error[:, 2])))
        worst = np.sort(heading)[-max(1, len(heading) // 10) :].sum() / max(heading.sum(), 1e-12)
        print(
            f"  {label:9s} {_stats(np.hypot(error[:, 0], error[:, 1]), 100.0)} cm, {_stats(heading, 1.0)} deg; "
            f"worst 10 % of links: {worst:.0%} of the heading error"
        )
    nodes_reference = reference[scans]
    chi2 = slam._graph.chi2(nodes_reference)  # each edge's at the reference poses: 3 on average if weighed right
    scan_matches = np.array([k for k in sequential if edges[k, 1] not in slam._unmatched])
    # the same with the reference's own per-pose noise (two poses an edge) added to each edge's covariance
    own = 2.0 * np.diag([reference_sigma[0] ** 2, reference_sigma[0] ** 2, math.radians(reference_sigma[1]) ** 2])
    error = slam._graph.errors(nodes_reference)
    widened = np.array(
        [
            e @ np.linalg.solve(np.linalg.inv(info) + own, e)
            for e, info in zip(error, slam._graph.information, strict=True)
        ]
    )
    parts = [
        f"{label} {np.mean(values[index]):.1f} / {np.median(values[index]):.1f}"
        for values in (chi2, widened)
        for label, index in (("scan matches", scan_matches), ("closures", np.flatnonzero(loop)))
        if len(index)
    ]
    print(
        "  chi-square at the reference poses (3: weighed right), mean / median: "
        + ", ".join(parts[: len(parts) // 2])
        + f"; with the reference's own noise ({reference_sigma[0] * 100:.1f} cm, {reference_sigma[1]} deg a pose): "
        + ", ".join(parts[len(parts) // 2 :])
    )
    for lag in (1, 8):
        a = np.arange(len(poses) - lag)
        error = np.degrees(
            np.abs(
                wrap_angle(
                    relative_motions(poses, a, a + lag)[:, 2] - relative_motions(nodes_reference, a, a + lag)[:, 2]
                )
            )
        )
        print(f"  heading error over {lag} node(s): rms {np.sqrt(np.mean(error**2)):.2f}, mean {error.mean():.2f} deg")
    along_across(poses, nodes_reference, measured, truth)
    offsets = []
    for k in range(1, len(poses) - 1):
        pair = np.array([k - 1, k]), np.array([k, k + 1])
        e = wrap_angle(relative_motions(poses, *pair)[:, 2] - relative_motions(nodes_reference, *pair)[:, 2])
        offsets.append((scans[k], math.degrees(0.5 * (e[0] - e[1]))))
    offsets = np.array(offsets)
    off = offsets[np.abs(offsets[:, 1]) > 1.5]
    worst = off[np.argsort(-np.abs(off[:, 1]))][:5]
    listed = ", ".join(f"scan {int(s)} {e:+.1f}" for s, e in worst)
    print(f"  nodes more than 1.5 deg off their neighbours' heading: {len(off)} ({listed})")


def _split(error: np.ndarray, displacement: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(along, across): the translation errors (K, 2) along and across the displacements (K, 2), each pair's frame."""
    length = np.maximum(np.hypot(displacement[:, 0], displacement[:, 1]), 1e-9)
    ux, uy = displacement[:, 0] / length, displacement[:, 1] / length
    return error[:, 0] * ux + error[:, 1] * uy, -error[:, 0] * uy + error[:, 1] * ux


def along_across(poses: np.ndarray, reference: np.ndarray, measured: np.ndarray, truth: np.ndarray) -> None:
    """The nodes' pair errors (1-10 m of path) split along and across the displacement; the links' along-track
    error and its tail."""
    i, j = relative_pairs(reference, 1.0, 10.0)
    if len(i):
        estimate, true = relative_motions(poses, i, j), relative_motions(reference, i, j)
        c, s = np.cos(true[:, 2]), np.sin(true[:, 2])
        dx, dy = estimate[:, 0] - true[:, 0], estimate[:, 1] - true[:, 1]
        along, across = _split(np.column_stack([c * dx + s * dy, -s * dx + c * dy]), true[:, :2])
        print(
            f"  node pairs 1-10 m: error along the way rms {100 * np.sqrt(np.mean(along**2)):.1f} cm, across "
            f"{100 * np.sqrt(np.mean(across**2)):.1f} cm"
        )
    along, _ = _split(measured[:, :2] - truth[:, :2], truth[:, :2])
    tail = np.abs(along) > 0.06
    print(
        f"  links along the way: rms {100 * np.sqrt(np.mean(along**2)):.1f} cm, median "
        f"{100 * np.median(np.abs(along)):.1f}; {int(tail.sum())} of {len(along)} links more than 6 cm off carry "
        f"{np.sum(along[tail] ** 2) / max(np.sum(along**2), 1e-12):.0%} of its square"
    )


def oracle_window(name: str, log, seed: int, every: int) -> None:
    """The front end's correlative match against a perfect window (see the module docstring)."""
    config = SlamConfig(**LOG_MOUNT)
    slam, scan_of, reference, odometry = mapped(log, seed, config)
    resolution, window = config.resolution, config.local_window
    rows = []
    for n in range(window, len(scan_of), every):
        members = [m for m in range(n - window, n) if m not in slam._unmatched]
        last = scan_of[n - 1]
        cloud = np.vstack(
            [
                transform_points(relative_pose(reference[last], reference[scan_of[m]]), slam._nodes[m].points)
                for m in members
            ]
        )
        delta = np.array(relative_pose(odometry[last], odometry[scan_of[n]]))
        linear, angular = _match_window(_odometry_information(delta), config)
        matcher = _window_reference(cloud, None, resolution, linear).matcher  # as the front end's, the window's pad
        match = matcher.match(slam._nodes[n].points, delta, linear, angular)
        true = np.array(relative_pose(reference[last], reference[scan_of[n]]))
        along, _ = _split((np.asarray(match.pose[:2]) - true[:2])[None, :], true[None, :2])
        rows.append((along[0], wrap_angle(match.pose[2] - true[2])))
    rows = np.array(rows)
    print(
        f"{name}: the front end's correlative match against its window at the corrected poses ({len(rows)} nodes): "
        f"along the way rms {100 * np.sqrt(np.mean(rows[:, 0] ** 2)):.1f} cm, median "
        f"{100 * np.median(np.abs(rows[:, 0])):.1f}, {int(np.sum(np.abs(rows[:, 0]) > 0.06))} more than 6 cm off; "
        f"heading rms {np.degrees(np.sqrt(np.mean(rows[:, 1] ** 2))):.2f} deg"
    )


def reference_noise(name: str, log, every: int, skip: int) -> None:
    reference = log.poses()
    resolution = 0.05
    points = [_beams(item.scan, 20.0)[2] for item in log.scans]
    world = [transform_points(pose, p) for pose, p in zip(reference, points, strict=True)]

    def correction(k: int, others: list[int]) -> np.ndarray:
        cloud = transform_points(
            np.array(relative_pose(reference[k], np.zeros(3))), np.vstack([world[m] for m in others])
        )
        table = ScoreMap.from_points(
            cloud, resolution, LIKELIHOOD_SIGMA_CELLS * resolution, 0.5 + LIKELIHOOD_PAD, cover=np.zeros((1, 2))
        )
        return CorrelativeMatcher(table).match(points[k], np.zeros(3), 0.3, math.radians(3.0)).pose

    rows = []
    for k in range(0, len(reference), every):
        near = [m for m in range(len(reference)) if math.hypot(*(reference[m, :2] - reference[k, :2])) < 10.0]
        before = [m for m in near if m < k - skip]
        after = [m for m in near if m > k + skip]
        if len(before) >= 3 and len(after) >= 3:
            rows.append((k, correction(k, before), correction(k, after)))
    before = np.array([r[1] for r in rows])
    after = np.array([r[2] for r in rows])
    parts = []
    for c, (label, scale, unit) in enumerate((("x", 100.0, "cm"), ("y", 100.0, "cm"), ("heading", 57.29578, "deg"))):
        a, b = before[:, c] - before[:, c].mean(), after[:, c] - after[:, c].mean()
        shared = max(float(np.mean(a * b)), 0.0)
        noise = max(float(np.mean(a**2)) - shared, 0.0)
        parts.append(f"{label} {math.sqrt(shared) * scale:.2f} {unit} (matcher {math.sqrt(noise) * scale:.2f})")
    print(
        f"{name}: the reference's own error per pose, rms, from {len(rows)} scans: "
        + ", ".join(parts)
        + " (x: along the way, one-sided clouds bias it)"
    )
    rng = np.random.default_rng(0)
    for sigma, degrees in ((0.015, 0.26), (0.02, 0.3)):
        noise = np.column_stack(
            [rng.normal(0, sigma, (len(reference), 2)), rng.normal(0, math.radians(degrees), len(reference))]
        )
        noisy = np.array([compose(p, d) for p, d in zip(reference, noise, strict=True)])
        rel = relative_error(noisy, reference)
        print(
            f"  exact but for per-pose noise {sigma * 100:.1f} cm, {degrees} deg: rel {rel.translation:.4f} m "
            f"{rel.rotation_deg:.3f} deg"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(DATA))
    parser.add_argument("--logs", nargs="*", default=["intel", "fhw", "aces", "orebro"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--reference", action="store_true", help="the corrected poses' own noise instead")
    parser.add_argument("--every", type=int, default=2)
    parser.add_argument(
        "--reference-sigma",
        nargs=2,
        type=float,
        default=[0.015, 0.26],
        metavar=("M", "DEG"),
        help="the reference's own noise per pose (chi-square with it added)",
    )
    parser.add_argument("--skip", type=int, default=1)
    parser.add_argument(
        "--oracle-window", action="store_true", help="the front end's match against a window at the corrected poses"
    )
    args = parser.parse_args()
    for name in args.logs:
        path = next(Path(args.data).glob(f"{name}*"), None)
        if path is None:
            sys.exit(f"no log {name} in {args.data}")
        log = read_carmen(path)
        if args.reference:
            reference_noise(name, log, args.every, args.skip)
        elif args.oracle_window:
            oracle_window(name, log, args.seed, args.every)
        else:
            links(name, log, args.seed, tuple(args.reference_sigma))
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores)")


if __name__ == "__main__":
    main()
