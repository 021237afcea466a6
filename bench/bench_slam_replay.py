"""GraphSlam alone on a maze run's recorded inputs (the mazes' drift): where its error comes from, measured
against the truth, without the explorer's closed loop (the same scans and odometry for every variant).

Record the inputs first: `bench/bench_mapping.py --library --record --out DIR` saves <run>.inputs.npz (every scan's
stamp, odometry, ranges and true pose). Then, per run:

- links: each sequential edge's measurement (the front end's) against the true motion: translation mm and heading deg
  (rms, mean: a bias, and the worst);
- heading: the nodes' heading error when added (online, before later closures move them): rms and the largest;
- closures: candidates searched, in the final graph, refused (ambiguous or on the window's edge / seen-through space /
  the chi-square gate), dropped after an optimization; then each outcome's count and how many of its matches were
  right (within 5 cm and 1 deg of the true relative pose: a right closure refused, or a wrong one refused);
- chi-square at the true poses (3 on average if weighed right): each scan-match edge, each closure, and runs of 10
  and 50 consecutive links composed against their compounded covariance (what the closures are weighed against: a
  link's error partly cancels along the chain);
- nodes: the final graph's nodes against the true poses (mean / max m, heading max deg);
- with --trace, each kept closure as it was added: its error and claimed covariance's chi-square at the truth, the
  gate's, the graph's prediction of it (at the truth), and the nodes' error before and after (which closure took the
  graph off, and what its covariance said);
- the map of the final graph judged against the world as bench_mapping.py judges a saved map (known, precise, walls).

Prints; asserts nothing. Usage: .venv/bin/python bench/bench_slam_replay.py DIR [--runs perfect_0 loops_0 ...]
[--slam KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np
import yaml
from bench_mapping import judge, recorded_inputs, shipped, stack_parameters  # the script's directory is on sys.path

import amr_mapping.slam as slam_module
from amr_mapping.errors import MappingError
from amr_mapping.slam import GraphSlam
from amr_mapping.slam_node import config_of
from amr_mapping.trajectory_error import relative_motions
from amr_maps.maze_families import generate
from amr_maps.world import world_from_dict
from amr_util.geometry import compose, relative_pose, wrap_angle
from amr_util.scan import ScanData

RIGHT_M, RIGHT_RAD = 0.05, math.radians(1.0)
"""A closure candidate's match this close to the true relative pose is right."""


def fed(path: Path, overrides: dict, trace: list | None = None) -> tuple[GraphSlam, np.ndarray, np.ndarray]:
    """One recorded run fed to GraphSlam (slam.yaml and maze_mapping's parameters, `overrides` over them): the SLAM,
    each node's true pose and its pose online (when it was added). With `trace` (a list), each kept closure is
    appended to it as it is added (_Traced)."""
    data = np.load(path)
    rows, ranges, scan = data["poses"], data["ranges"], data["scan"]
    params = {**shipped("slam", "slam.yaml"), **stack_parameters("slam"), **overrides}
    slam = GraphSlam(config_of(params))
    truth, online = [], []
    traced = _Traced(slam, truth, trace) if trace is not None else None
    for row, reading in zip(rows, ranges, strict=True):
        if traced is not None:
            traced.current = row[4:7]
        try:
            update = slam.add(int(row[0]), row[1:4], ScanData(reading, *scan))
        except MappingError:
            continue
        if update.node_added:
            truth.append(row[4:7])
            online.append(update.pose)
            if traced is not None:
                traced.node_error()
    return slam, np.array(truth), np.array(online)


class _Traced:
    """Each kept closure against the truth, as GraphSlam adds it: its error (cm, deg), its claimed covariance's
    standard deviations and chi-square at the true relative pose, the gate's chi-square, the graph's prediction of it
    (its standard deviations, and the truth's chi-square against the gate's spread: how far the graph's own pose
    was), and the nodes' error (mean / max m) just before and 20 nodes after (what the closure did to the graph)."""

    def __init__(self, slam: GraphSlam, truth: list, out: list) -> None:
        self.slam, self.truth, self.out = slam, truth, out
        self.current = None
        self.errors: list[tuple[float, float]] = []
        self.gates: dict = {}
        gate, add_edge = slam._gate, slam._graph.add_edge

        def traced_gate(submap, candidate, marginals):
            result = gate(submap, candidate, marginals)
            a, n = submap.anchor, candidate.node
            predicted = np.array(relative_pose(slam._graph.pose(a), slam._graph.pose(n)))
            spread = slam._relative_covariance(marginals[0], a, n)
            closure = slam._closure_covariance(
                submap, candidate.points, candidate.matched, candidate.aligned_information
            )
            innovation, off = candidate.matched - predicted, self._true(a, n) - predicted
            innovation[2], off[2] = wrap_angle(innovation[2]), wrap_angle(off[2])
            total = closure + spread
            self.gates[(a, n)] = (
                float(innovation @ np.linalg.solve(total, innovation)),
                float(off @ np.linalg.solve(total, off)),
                np.sqrt(np.diag(spread)),
            )
            return result

        def traced_add_edge(i, j, measurement, information, loop=False):
            if loop:
                error = np.asarray(measurement, dtype=float) - self._true(i, j)
                error[2] = wrap_angle(error[2])
                # the information is in node j's frame (GraphSlam: _rotated): back to the anchor's
                c, s = math.cos(measurement[2]), math.sin(measurement[2])
                rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
                covariance = rotation @ np.linalg.inv(information) @ rotation.T
                gate_chi2, prediction_chi2, spread = self.gates.get((i, j), (math.nan, math.nan, np.full(3, math.nan)))
                self.out.append(
                    {
                        "node": j,
                        "anchor": i,
                        "error": error,
                        "sigma": np.sqrt(np.diag(covariance)),
                        "chi2": float(error @ np.linalg.solve(covariance, error)),
                        "gate": gate_chi2,
                        "prediction": prediction_chi2,
                        "spread": spread,
                        "before": self.errors[-1] if self.errors else (0.0, 0.0),
                        "at": len(self.errors),
                        "errors": self.errors,  # grows: the nodes' error after it
                    }
                )
            return add_edge(i, j, measurement, information, loop=loop)

        slam._gate, slam._graph.add_edge = traced_gate, traced_add_edge

    def _true(self, first: int, last: int) -> np.ndarray:
        poses = [self.truth[k] if k < len(self.truth) else self.current for k in (first, last)]
        return np.array(relative_pose(*poses))

    def node_error(self) -> None:
        error = np.hypot(*(self.slam._graph.poses[:, :2] - np.array(self.truth)[:, :2]).T)
        self.errors.append((float(error.mean()), float(error.max())))


def print_trace(trace: list) -> None:
    print(
        "            kept closures against the truth (error, claim sigma, chi-square at the truth / gate / the "
        "graph's prediction at the truth, the prediction's sigma; nodes' error m mean/max before -> 20 nodes after):"
    )
    for t in trace:
        e, s, p = t["error"], t["sigma"], t["spread"]
        after = t["errors"][min(t["at"] + 20, len(t["errors"])) - 1]
        print(
            f"            ({t['anchor']:4d}, {t['node']:4d}) {100 * math.hypot(e[0], e[1]):5.1f} cm "
            f"{math.degrees(e[2]):+5.2f} deg, claim {100 * s[0]:.1f}/{100 * s[1]:.1f} cm {math.degrees(s[2]):.2f} deg, "
            f"chi2 {t['chi2']:7.1f} / "
            f"{t['gate']:4.1f} / {t['prediction']:5.1f}, prediction {100 * p[0]:.1f}/{100 * p[1]:.1f} cm "
            f"{math.degrees(p[2]):.2f} deg; {t['before'][0]:.3f}/{t['before'][1]:.3f} -> {after[0]:.3f}/{after[1]:.3f}",
            flush=True,
        )


def replay(path: Path, overrides: dict, trace: list | None = None) -> dict:
    """One recorded run through GraphSlam, optimized at its end: its errors against the truth (`trace`: fed's)."""
    started = time.process_time()
    slam, truth, online = fed(path, overrides, trace)
    slam.optimize()
    seconds = time.process_time() - started
    poses, edges, loop = slam.graph()
    sequential = np.flatnonzero(~loop)
    # a node's link from its newest source (one link a node, or the newest of several: slam.LINK_SHARES)
    newest = np.lexsort((edges[sequential, 0], edges[sequential, 1]))
    ends = edges[sequential[newest], 1]
    sequential = sequential[newest][np.append(ends[1:] != ends[:-1], True)]
    i, j = edges[sequential, 0], edges[sequential, 1]
    error = slam._graph.measurements[sequential] - relative_motions(truth, i, j)
    link_heading = np.degrees(wrap_angle(error[:, 2]))
    heading_online = np.degrees(wrap_angle(online[:, 2] - truth[:, 2]))
    node = np.hypot(*(poses[:, :2] - truth[:, :2]).T)
    chi2 = slam._graph.chi2(truth)  # each edge's chi-square at the true poses: 3 on average if weighed right
    order = sequential[np.argsort(j)]  # edge (k - 1, k) for k = 1 ..
    chains = [
        chain_chi2(slam._graph.measurements[order], slam._graph.information[order], truth, length)
        for length in (10, 50)
    ]
    loop_error = slam._graph.measurements[loop] - relative_motions(truth, edges[loop, 0], edges[loop, 1])
    outcomes = {}
    for anchor, node_index, outcome, matched in slam.closure_outcomes:
        true = relative_motions(truth, np.array([anchor]), np.array([node_index]))[0]
        right = math.hypot(*(matched[:2] - true[:2])) < RIGHT_M and abs(wrap_angle(matched[2] - true[2])) < RIGHT_RAD
        count = outcomes.setdefault(outcome, [0, 0])
        count[0] += 1
        count[1] += int(right)
    family, _, seed = path.name.split(".")[0].rpartition("_")
    world = world_from_dict(generate(family, int(seed)), source=f"{family} seed {seed}")
    map_figures = judge(slam.occupancy_grid(), world)
    return {
        "name": path.name.split(".")[0],
        "nodes": len(poses),
        "link_mm": 1000.0 * math.sqrt(float(np.mean(np.sum(error[:, :2] ** 2, axis=1)))),
        "link_deg": (
            float(np.sqrt(np.mean(link_heading**2))),
            float(link_heading.mean()),
            float(np.abs(link_heading).max()),
        ),
        "heading": (float(np.sqrt(np.mean(heading_online**2))), float(np.abs(heading_online).max())),
        "closures": (
            slam.searched_closures,
            int(loop.sum()),
            slam.ambiguous_closures,
            slam.inconsistent_closures,
            slam.rejected_closures,
            slam.dropped_closures,
        ),
        "node": (
            float(node.mean()),
            float(node.max()),
            float(np.abs(np.degrees(wrap_angle(poses[:, 2] - truth[:, 2]))).max()),
        ),
        "seconds": seconds,
        "outcomes": outcomes,
        "chi2": (float(np.mean(chi2[~loop])), float(np.median(chi2[~loop])), *_mean_median(chi2[loop]), *chains),
        "loop_error": (
            1000.0 * math.sqrt(float(np.mean(np.sum(loop_error[:, :2] ** 2, axis=1)))) if loop.any() else math.nan,
            float(np.degrees(np.sqrt(np.mean(wrap_angle(loop_error[:, 2]) ** 2)))) if loop.any() else math.nan,
        ),
        **map_figures,
    }


def chain_chi2(measurements: np.ndarray, information: np.ndarray, truth: np.ndarray, length: int) -> float:
    """Mean chi-square of runs of `length` consecutive links (measurements (N - 1, 3) of edges (k - 1, k), their
    informations in node k's frame) composed, against their covariance compounded along the run, at the true poses
    (non-overlapping runs)."""
    values = []
    for start in range(0, len(measurements) - length + 1, length):
        z, covariance = np.zeros(3), np.zeros((3, 3))
        for k in range(start, start + length):
            step = measurements[k]
            c, s = math.cos(step[2]), math.sin(step[2])
            # the run so far seen from the step's end (Ad(step^-1)), then the step's own error
            adjoint = np.array(
                [[c, s, -s * step[0] + c * step[1]], [-s, c, -c * step[0] - s * step[1]], [0.0, 0.0, 1.0]]
            )
            covariance = adjoint @ covariance @ adjoint.T + np.linalg.inv(information[k])
            z = np.array(compose(z, step))
        true = np.array(relative_pose(truth[start], truth[start + length]))
        c, s = math.cos(z[2]), math.sin(z[2])
        error = np.array(
            [c * (true[0] - z[0]) + s * (true[1] - z[1]), -s * (true[0] - z[0]) + c * (true[1] - z[1]), 0.0]
        )
        error[2] = wrap_angle(true[2] - z[2])
        values.append(float(error @ np.linalg.solve(covariance, error)))
    return float(np.mean(values)) if values else math.nan


def _mean_median(values: np.ndarray) -> tuple[float, float]:
    return (float(np.mean(values)), float(np.median(values))) if len(values) else (math.nan, math.nan)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory", type=Path)
    parser.add_argument("--runs", nargs="*", default=None, help="run names (perfect_0 ...); default every recording")
    parser.add_argument("--slam", nargs="*", default=[], metavar="KEY=VALUE", help="slam parameters over slam.yaml's")
    parser.add_argument(
        "--constant",
        nargs="*",
        default=[],
        metavar="NAME=VALUE",
        help="amr_mapping.slam module constants (experiments)",
    )
    parser.add_argument(
        "--trace", action="store_true", help="each kept closure against the truth as it was added (_Traced)"
    )
    args = parser.parse_args()
    overrides = {}
    for item in args.slam:
        key, _, value = item.partition("=")
        overrides[key] = yaml.safe_load(value)
    for item in args.constant:
        name, _, value = item.partition("=")
        if not hasattr(slam_module, name):
            parser.error(f"--constant {item!r}: amr_mapping.slam has no {name}")
        setattr(slam_module, name, yaml.safe_load(value))
    paths = recorded_inputs(args.directory, args.runs)
    print(
        f"{'run':11s} {'nodes':>5s} {'link mm':>7s} {'link deg rms/mean/max':>22s} {'heading rms/max':>15s} "
        f"{'closures srch/kept/amb/clear/chi2/drop':>38s} {'node m mean/max, deg':>21s} {'known':>5s} {'precise':>7s} "
        f"{'walls':>5s} {'cpu s':>5s}"
    )
    for path in paths:
        trace = [] if args.trace else None
        r = replay(path, overrides, trace)
        rms, mean, worst = r["link_deg"]
        print(
            f"{r['name']:11s} {r['nodes']:5d} {r['link_mm']:7.2f} {rms:8.3f}/{mean:+.3f}/{worst:5.2f} "
            f"{r['heading'][0]:7.2f}/{r['heading'][1]:5.2f} {'/'.join(str(c) for c in r['closures']):>38s} "
            f"{r['node'][0]:.3f}/{r['node'][1]:.3f}, {r['node'][2]:4.1f} {r['known']:5.3f} {r['precise']:7.3f} "
            f"{r['walls']:5.3f} {r['seconds']:5.0f}",
            flush=True,
        )
        print(
            "            closure candidates (right: within 5 cm and 1 deg of the truth): "
            + ", ".join(f"{k} {n} ({right} right)" for k, (n, right) in sorted(r["outcomes"].items())),
            flush=True,
        )
        print(
            "            chi-square at the true poses (3: weighed right), mean / median: scan matches "
            f"{r['chi2'][0]:.1f} / {r['chi2'][1]:.1f}, closures {r['chi2'][2]:.1f} / {r['chi2'][3]:.1f}, "
            f"runs of 10 / 50 links (mean) {r['chi2'][4]:.1f} / {r['chi2'][5]:.1f}; closures' "
            f"error rms {r['loop_error'][0]:.1f} mm, {r['loop_error'][1]:.2f} deg",
            flush=True,
        )
        if trace is not None:
            print_trace(trace)
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores)")


if __name__ == "__main__":
    main()
