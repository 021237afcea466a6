"""Are GraphSlam's scan estimates weighed right? Each one's error against the truth over its own covariance
(chi-square, 3 on average if weighed right), and over the covariance Olson's correlative matcher would give it
(Olson 2009, "Real-time correlative scan matching": the second moments of the match's response over a window of
the lattice, the score taken as a likelihood at a scale, plus the field's quantization: res / sqrt(12) in x and y,
that over the points' RMS range in heading), at several scales (the calibration of the edges).

The estimates are taken where GraphSlam makes them, before anything else weighs in: a link's is the scan's estimate
in the previous node's frame before its fusion with the odometry (_refined: the correlative match and its
point-to-line refinement; its covariance the deciding one's own), a closure's its refined match in the anchor's
frame at the gate (its covariance the refinement's and, separately, the submap's layout). Truth: a maze recording's
true poses (`bench_mapping.py --library --record --out DIR`: DIR/<run>.inputs.npz), or a CARMEN log's corrected
poses (odometry synthesized as in bench_slam_logs.py, seed 0; those carry their own noise, 1.5 cm and 0.26 deg a
pose on aces: `--reference-sigma` adds it to every covariance in a second line). Closures: only the right ones
(within 5 cm and 1 deg of the truth; a wrong one's chi-square says nothing of the weights).

Printed per input and kind (links, closures): the errors' rms (x, y cm, heading deg), the median standard
deviations each covariance claims, and the chi-square mean / median of: the covariance GraphSlam uses ("own"), the
response's at each scale, and for closures the response's plus the layout.

Prints; asserts nothing. Usage: .venv/bin/python bench/bench_slam_calibration.py INPUT ... (a .inputs.npz, or a log
name: aces, fhw, intel, orebro) [--scales 50 200 800] [--cells 6] [--angle-deg 2]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np
from bench_slam_links import DATA, mapped  # the script's directory is on sys.path
from bench_slam_replay import fed

import amr_mapping.slam as slam_module
from amr_mapping.slam import GraphSlam, SlamConfig
from amr_maps.scan_matcher import default_angular_step
from amr_util.geometry import relative_pose, wrap_angle

RIGHT_M, RIGHT_RAD = 0.05, math.radians(1.0)


def response_covariances(matcher, points, pose, resolution, scales, cells, angle) -> dict[float, np.ndarray]:
    """Olson's covariance of an estimate at `pose`: the lattice (whole cells, the matcher's angular step) within
    +-cells cells and +-angle rad of it (window_scores), weights exp(scale (score - best)), second moments about the
    estimate (its spread and its offset from the response's mass), plus the field's quantization; one per scale."""
    step = default_angular_step(points, resolution)
    turns = max(cells, math.ceil(angle / step))
    poses, scores = matcher.window_scores(points, pose, cells * resolution, turns * step, step)
    offsets = poses - np.asarray(pose, dtype=float)
    offsets[:, 2] = wrap_angle(offsets[:, 2])
    radius = max(float(np.sqrt(np.mean(np.sum(points**2, axis=1)))), resolution)
    q = resolution / math.sqrt(12.0)
    floor = np.diag([q * q, q * q, (q / radius) ** 2])
    found = {}
    for scale in scales:
        weight = np.exp(scale * (scores - scores.max()))
        found[scale] = (offsets * weight[:, None]).T @ offsets / weight.sum() + floor
    return found


class Recorder:
    """Wraps GraphSlam's estimators (module functions and methods, restored by close) to keep each estimate, its
    own covariance and the response's: records (kind, first node, second node, estimate, own, responses, layout)."""

    def __init__(self, scales, cells: int, angle: float) -> None:
        self.records: list[tuple] = []
        self._saved = []
        current: dict = {}
        refined = slam_module._refined
        closure_covariance = GraphSlam._closure_covariance
        match_local = GraphSlam._match_local
        step_candidate = GraphSlam._step_candidate

        def recording_match_local(slam, *args, **kwargs):
            current["slam"] = slam
            return match_local(slam, *args, **kwargs)

        def recording_refined(reference, points, pose, resolution):
            fused, weight, covariance = refined(reference, points, pose, resolution)
            node = len(current["slam"]._nodes)  # the node this scan becomes
            responses = response_covariances(reference.matcher, points, fused, resolution, scales, cells, angle)
            self.records.append(("link", node - 1, node, fused.copy(), covariance.copy(), responses, None))
            return fused, weight, covariance

        def recording_step_candidate(slam, candidate, *args, **kwargs):
            current["candidate"] = candidate
            return step_candidate(slam, candidate, *args, **kwargs)

        def recording_closure_covariance(slam, submap, points, matched, aligned_information):
            covariance = closure_covariance(slam, submap, points, matched, aligned_information)
            lever = np.array([[1.0, 0.0, -matched[1]], [0.0, 1.0, matched[0]], [0.0, 0.0, 1.0]])
            layout = lever @ submap.layout @ lever.T
            resolution = slam.config.resolution
            responses = response_covariances(submap.matcher, points, matched, resolution, scales, cells, angle)
            node = current["candidate"].node
            self.records.append(
                ("closure", submap.anchor, node, matched.copy(), covariance - layout, responses, layout)
            )
            return covariance

        for owner, name, value in (
            (slam_module, "_refined", recording_refined),
            (GraphSlam, "_match_local", recording_match_local),
            (GraphSlam, "_step_candidate", recording_step_candidate),
            (GraphSlam, "_closure_covariance", recording_closure_covariance),
        ):
            self._saved.append((owner, name, getattr(owner, name)))
            setattr(owner, name, value)

    def close(self) -> None:
        for owner, name, value in self._saved:
            setattr(owner, name, value)


def run_maze(path: Path) -> np.ndarray:
    """The recorded run through GraphSlam (slam.yaml and maze_mapping's parameters): each node's true pose."""
    return fed(path, {})[1]


def run_log(name: str) -> np.ndarray:
    """The log through GraphSlam (odometry synthesized, seed 0; the laser at the log's poses): each node's
    corrected pose."""
    from amr_datasets.carmen import LOG_MOUNT, read_carmen

    _, scan_of, reference, _ = mapped(read_carmen(next(DATA.glob(f"{name}*.log*"))), 0, SlamConfig(**LOG_MOUNT))
    return reference[scan_of]


def report(name: str, records: list, truth: np.ndarray, scales, added: np.ndarray) -> None:
    def chi2(error, covariance) -> float:
        return float(error @ np.linalg.solve(covariance + added, error))

    def sigma(covariances) -> str:
        s = np.median([np.sqrt(np.diag(c)) for c in covariances], axis=0)
        return f"{100 * s[0]:.1f}, {100 * s[1]:.1f} cm, {math.degrees(s[2]):.2f} deg"

    def figure(values) -> str:
        return f"{np.mean(values):.1f} / {np.median(values):.1f}"

    for kind in ("link", "closure"):
        rows = []
        for record in records:
            if record[0] != kind or record[2] >= len(truth):
                continue
            error = record[3] - np.array(relative_pose(truth[record[1]], truth[record[2]]))
            error[2] = wrap_angle(error[2])
            if kind == "link" or (math.hypot(*error[:2]) < RIGHT_M and abs(error[2]) < RIGHT_RAD):
                rows.append((error, record))
        if not rows:
            continue
        errors = np.array([e for e, _ in rows])
        rms = np.sqrt(np.mean(errors**2, axis=0))
        own = [r[4] if r[6] is None else r[4] + r[6] for _, r in rows]
        line = (
            f"{name} {kind}s: {len(rows)}, error rms {100 * rms[0]:.1f}, {100 * rms[1]:.1f} cm, "
            f"{math.degrees(rms[2]):.2f} deg; sigma median: own {sigma(own)}, response at {scales[len(scales) // 2]:g} "
            f"{sigma([r[5][scales[len(scales) // 2]] for _, r in rows])}\n    chi-square mean / median: own "
            + figure([chi2(e, c) for (e, _), c in zip(rows, own, strict=True)])
            + "; response "
            + ", ".join(f"at {s:g} {figure([chi2(e, r[5][s]) for e, r in rows])}" for s in scales)
        )
        if kind == "closure":
            line += "; response + layout " + ", ".join(
                f"at {s:g} {figure([chi2(e, r[5][s] + r[6]) for e, r in rows])}" for s in scales
            )
        print(line, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("inputs", nargs="+", help="maze recordings (.inputs.npz) or log names")
    parser.add_argument("--scales", nargs="*", type=float, default=[50.0, 200.0, 800.0])
    parser.add_argument("--cells", type=int, default=6, help="the response's window: +- cells in x and y")
    parser.add_argument("--angle-deg", type=float, default=2.0, help="... and +- this in heading (6 steps at least)")
    parser.add_argument("--reference-sigma", nargs=2, type=float, default=[0.015, 0.26], metavar=("M", "DEG"))
    args = parser.parse_args()
    for item in args.inputs:
        recorder = Recorder(args.scales, args.cells, math.radians(args.angle_deg))
        started = time.process_time()
        try:
            is_log = not item.endswith(".npz")
            truth = run_log(item) if is_log else run_maze(Path(item))
        finally:
            recorder.close()
        name = item if is_log else Path(item).name.split(".")[0]
        report(name, recorder.records, truth, args.scales, np.zeros((3, 3)))
        if is_log:
            m, deg = args.reference_sigma
            own = 2.0 * np.diag([m * m, m * m, math.radians(deg) ** 2])  # the reference's noise at both poses
            report(
                f"{name} (+ the reference's {100 * m:g} cm, {deg:g} deg a pose)",
                recorder.records,
                truth,
                args.scales,
                own,
            )
        print(
            f"    CPU {time.process_time() - started:.0f} s, load average {os.getloadavg()[0]:.2f} (2 cores)",
            flush=True,
        )


if __name__ == "__main__":
    main()
