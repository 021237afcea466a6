"""How far apart two beams' errors are shared: the correlation of the measurement model's per-beam log-likelihood at
the true pose, by the distance between the beams' end points, on real robots' logs.

    .venv/bin/python bench/bench_beam_correlation.py [--data DIR] [--logs aces orebro] [--max-beams 60]
                                                    [--worlds hard_maze inner_maze] [--seconds 120]

For each CARMEN log in DIR (default: ../shared/data/carmen beside the repository), on the map of its own scans at
their corrected poses (as bench_log_localization.py), each scan's beams (the filter's max_beams selection) are scored
at the scan's corrected pose by the places' model (the likelihood field with the free path, each beam at its best
within a cell and half a degree: ParticleFilter._log_likelihood with places=True). The (Pearson) correlation of two
beams' terms is taken over every pair of beams of the same scan, binned by the distance between their end points (sensor
frame). Then the exponential model of amr_localization.beam_correlation, rho(d) = exp(-d / l), is fitted to the
bins (least squares, weighted by pairs), which is what beam_correlation_length stands for. --worlds does the same
in simulator worlds (their own map, a scan every 0.5 s of wall following): the map is the world there, and only the
LiDAR's noise and the map's cells are left to correlate.

Then scans against scans: each scan's evidence for its true pose (the weighted log-likelihood there less at poses
30 cm and 0.1 rad around it, NEIGHBOURS, averaged: what one scan tells the filter), its correlation between two scans
binned by the path travelled between them, and exp(-s / L) fitted. An object the map lacks, seen by scan after scan,
tells the filter the same thing each time: for scans spaced much closer than L, each carries s / 2L of an independent
scan's information (an exponentially correlated sequence's effective sample size), which is what the filter's
scan_correlation_distance counts as 2 L.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

import numpy as np
import yaml
from bench_log_localization import DATA, ROOT, served, shipped_filter_parameters

from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import read_parameter_file
from amr_datasets.carmen import log_name, read_carmen
from amr_datasets.odometry import OdometryNoiseModel
from amr_evaluation.log_localization import filter_for, log_map
from amr_localization.beam_correlation import beam_weights
from amr_localization.particle_filter import FREE_PATH_MARGIN, NUDGES, ParticleFilter
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_localization.scan_beams import select_beams
from amr_maps.rasterize import rasterize_world
from amr_maps.world import load_world
from amr_simulation.config import SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.geometry import compose
from amr_util.scan import scan_of

EDGES = np.array([0.0, 0.1, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, math.inf])
"""m: the bins of end-point distance."""
LENGTHS = np.linspace(0.05, 3.0, 591)
"""m: the correlation lengths tried by the fit."""
TRAVEL_EDGES = np.array([0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, math.inf])
"""m: the bins of travel between two scans."""
TRAVEL_LENGTHS = np.linspace(0.1, 20.0, 1991)
"""m: the scans' correlation lengths tried by the fit."""
NEIGHBOURS = np.array(
    [[0.3, 0.0, 0.0], [-0.3, 0.0, 0.0], [0.0, 0.3, 0.0], [0.0, -0.3, 0.0], [0.0, 0.0, 0.1], [0.0, 0.0, -0.1]]
)
"""(x m, y m, theta rad) in the robot's frame: the poses a scan's evidence for its true pose is taken against (the
scale of a keyframe's odometry error)."""


class BinnedCorrelation:
    """Pearson correlations of pairs of values, binned by a key of each pair (a distance): sums accumulated pair by
    pair around a mean given beforehand."""

    def __init__(self, edges: np.ndarray, mean: float) -> None:
        self.edges, self.mean = edges, mean
        self.products, self.first, self.second, self.pairs = (np.zeros(len(edges) - 1) for _ in range(4))

    def add(self, first: np.ndarray, second: np.ndarray, keys: np.ndarray) -> None:
        bins = np.digitize(keys, self.edges) - 1
        a, b = first - self.mean, second - self.mean
        np.add.at(self.products, bins, a * b)
        np.add.at(self.first, bins, a**2)
        np.add.at(self.second, bins, b**2)
        np.add.at(self.pairs, bins, 1.0)

    def result(self) -> tuple[np.ndarray, np.ndarray]:
        """(correlation per bin, pairs per bin)."""
        scale = np.sqrt(self.first * self.second)
        return np.divide(self.products, scale, out=np.zeros_like(self.products), where=scale > 0), self.pairs


def correlation_by_distance(pf, poses: np.ndarray, scans, max_beams: int) -> tuple[np.ndarray, ...]:
    """(correlation per bin, pairs per bin, each scan's count of independent beams by the filter's weights, each
    scan's evidence for its true pose against its NEIGHBOURS): the scans' beams scored at their true poses (and
    around them) by the filter `pf`'s places' model."""
    scored, evidence = [], []
    for pose, scan in zip(poses, scans, strict=True):
        beams = select_beams(scan, max_beams)
        near = np.array([pose, *(tuple(compose(tuple(pose), tuple(offset))) for offset in NEIGHBOURS)], dtype=float)
        terms = pf._laser.best_free_path(near, NUDGES * pf._nudge_step, beams, FREE_PATH_MARGIN)
        returned = beams.returned
        ends = np.column_stack([beams.ranges * np.cos(beams.angles), beams.ranges * np.sin(beams.angles)])
        weights = beam_weights(beams, pf.config.beam_correlation_length)
        scored.append((terms[0][returned], ends[returned], weights[returned]))
        totals = terms @ weights
        evidence.append(float(np.mean(totals[0] - totals[1:])))
    binned = BinnedCorrelation(EDGES, float(np.concatenate([terms for terms, _, _ in scored]).mean()))
    for terms, ends, _ in scored:
        upper = np.triu_indices(len(terms), 1)
        distance = np.hypot(*(ends[:, None, :] - ends[None, :, :]).transpose(2, 0, 1))[upper]
        binned.add(terms[upper[0]], terms[upper[1]], distance)
    correlation, pairs = binned.result()
    return correlation, pairs, np.array([weights.sum() for _, _, weights in scored]), np.array(evidence)


def correlation_by_travel(poses: np.ndarray, evidence: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(correlation per bin, pairs per bin) of two scans' evidence for their true pose against its NEIGHBOURS (what
    each scan tells the filter), binned by the path travelled between them (TRAVEL_EDGES)."""
    path = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
    upper = np.triu_indices(len(evidence), 1)
    binned = BinnedCorrelation(TRAVEL_EDGES, float(evidence.mean()))
    binned.add(evidence[upper[0]], evidence[upper[1]], np.abs(path[upper[1]] - path[upper[0]]))
    return binned.result()


def log_case(path: Path) -> tuple:
    """A CARMEN log: the filter on the map of its scans at their corrected poses, those poses, its scans."""
    log = read_carmen(path)
    pf = filter_for(log, served(log_map(log)), shipped_filter_parameters(), 0, OdometryNoiseModel())
    return pf, log.poses(), [item.scan for item in log.scans]


def world_case(name: str, seconds: float, period: float) -> tuple:
    """A simulator world: the filter on the world's own map (rasterized as the stacks serve it), the true poses and
    scans every `period` s of `seconds` of wall following (the simulator's default LiDAR and encoder noise)."""
    world = load_world(ROOT / "config" / "worlds" / f"{name}.yaml")
    sim = Simulator(world, SimulationConfig())
    resolution = yaml.safe_load((ROOT / "config" / "particle_filter.yaml").read_text())["particle_filter"][
        "ros__parameters"
    ]["map_resolution"]
    config = ParticleFilterConfig(**shipped_filter_parameters(real=False))
    pf = ParticleFilter(rasterize_world(world, resolution), config)
    follower = WallFollower(read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml"))
    poses, scans, next_record = [], [], 0.0
    while sim.time < seconds:
        scan = scan_of(sim)
        if sim.time >= next_record:
            poses.append(tuple(sim.pose))
            scans.append(scan)
            next_record += period
        command = follower.compute(scan, *sim.odom_twist, sim.time)
        sim.step(command.v, command.w)
    return pf, np.array(poses), scans


def fitted_length(
    correlation: np.ndarray, pairs: np.ndarray, edges: np.ndarray = EDGES, lengths: np.ndarray = LENGTHS
) -> float:
    """The l of exp(-d / l) closest to the bins (their middles, the last finite bin's edges only), pairs-weighted."""
    middles = 0.5 * (edges[:-1] + edges[1:])
    use = np.isfinite(middles) & (pairs > 0)
    errors = [np.sum(pairs[use] * (correlation[use] - np.exp(-middles[use] / length)) ** 2) for length in lengths]
    return float(lengths[int(np.argmin(errors))])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--logs", nargs="*", help="log names (the file name's first word); default: every log")
    parser.add_argument("--max-beams", type=int, default=shipped_filter_parameters()["max_beams"])
    parser.add_argument("--worlds", nargs="*", default=[], help="simulator worlds (config/worlds) to measure too")
    parser.add_argument("--seconds", type=float, default=120.0, help="s of wall following in each world")
    args = parser.parse_args()
    files = sorted(args.data.glob("*.log*"))
    if args.logs:
        files = [f for f in files if log_name(f) in args.logs]
    if not files and not args.worlds:
        print(f"no CARMEN log in {args.data}", file=sys.stderr)
        return 2
    labels = [
        f"{low:g}-{high:g}" if math.isfinite(high) else f">{low:g}"
        for low, high in zip(EDGES[:-1], EDGES[1:], strict=True)
    ]
    print("log | " + " | ".join(labels) + " m | fitted l (m) | independent beams per scan, median (5-95 %)")
    cases = [(log_name(path), lambda path=path: log_case(path)) for path in files]
    cases += [(f"{name} (simulated)", lambda name=name: world_case(name, args.seconds, 0.5)) for name in args.worlds]
    by_travel = []
    for label, case in cases:
        pf, poses, scans = case()
        correlation, pairs, independent, means = correlation_by_distance(pf, poses, scans, args.max_beams)
        low, median, high = np.percentile(independent, [5, 50, 95])
        print(
            f"{label} | "
            + " | ".join(f"{value:.2f}" for value in correlation)
            + f" | {fitted_length(correlation, pairs):.2f} | {median:.1f} ({low:.1f}-{high:.1f})",
            flush=True,
        )
        by_travel.append((label, *correlation_by_travel(np.asarray(poses), means)))
    travel_labels = [
        f"{low:g}-{high:g}" if math.isfinite(high) else f">{low:g}"
        for low, high in zip(TRAVEL_EDGES[:-1], TRAVEL_EDGES[1:], strict=True)
    ]
    print(
        "\nscans: the correlation of two scans' evidence for their true pose (the weighted log-likelihood there less "
        "at 30 cm and 0.1 rad around it, mean) by the path between them\n"
        "log | " + " | ".join(travel_labels) + " m | fitted L (m) | scan_correlation_distance 2 L (m)"
    )
    for label, correlation, pairs in by_travel:
        length = fitted_length(correlation, pairs, TRAVEL_EDGES, TRAVEL_LENGTHS)
        print(
            f"{label} | " + " | ".join(f"{value:.2f}" for value in correlation) + f" | {length:.1f} | {2 * length:.1f}"
        )
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    sys.exit(main())
