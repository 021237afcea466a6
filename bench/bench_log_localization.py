"""Localization on real robots' logs: tracking from the first corrected pose and global localization from none.

    .venv/bin/python bench/bench_log_localization.py [--data DIR] [--logs intel aces] [--modes tracking global]
                                                    [--seeds 0 1] [--ros] [--reverse] [--stride N]

For each CARMEN log in DIR (default: ../shared/data/carmen beside the repository), the map is the log's own scans
at their corrected poses (known-pose log-odds mapping, 5 cm cells, saved and loaded as map_server serves it), the
odometry is synthesized from the corrected poses (amr_datasets.odometry defaults: 5 % noise, +1 % scale, 0.5 deg/m
heading bias, seeded), and the shipped filter configuration runs one update per scan
(amr_evaluation.log_localization). Prints per run: travel before `localized`, scans localized, declarations more
than 0.5 m or 10 deg off, median error while localized, and the filter update's time (median, p95, max).

--beside NAME: each log's map holds another building too (the log NAME's, or with `next` the next log's in name
order, placed --gap m, default 20, beyond the log's own: amr_evaluation.log_localization.log_map_beside), a map
twice one building's size with two buildings' look-alikes: what a larger held-back log asks of global localization.

--reverse plays each log backwards (amr_datasets.carmen.played_backwards: the same building on another path, the
laser facing away from the way the robot drives): a proxy for logs not seen. --stride N keeps every N-th scan
(keyframes N times farther apart; the map made of the scans kept).

--ros plays each log through the ROS nodes instead (log_player in lockstep into particle_filter on a map_server
file): the same figures from /pose against /ground_truth, plus the round trip (scan out, /pose in).
Run it with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a ROS_DOMAIN_ID of its own.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import yaml

from amr_datasets.carmen import log_name, played_backwards, read_carmen, thinned
from amr_evaluation.log_localization import log_map, log_map_beside, run_log
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_maps.map_io import load_map, save_map

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "carmen"


def shipped_filter_parameters(real: bool = True) -> dict:
    """The filter's own parameters as a real robot's stack sets them: config/particle_filter.yaml, then
    config/particle_filter_real.yaml over it (the logs are real buildings); real=False: the first alone (the
    simulator's stacks)."""
    values = {}
    for name in ("particle_filter.yaml", "particle_filter_real.yaml")[: 2 if real else 1]:
        values |= yaml.safe_load((ROOT / "config" / name).read_text())["particle_filter"]["ros__parameters"]
    names = {spec.name for spec in ParticleFilterConfig.parameter_specs()}
    return {name: value for name, value in values.items() if name in names}


def served(grid):
    """The map as map_server serves it (saved and loaded again), for the library run as for the ROS one."""
    with tempfile.TemporaryDirectory() as directory:
        save_map(grid, Path(directory) / "map.yaml")
        return load_map(Path(directory) / "map.yaml", frame_id=grid.frame_id)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--logs", nargs="*", help="log names (the file name's first word); default: every log")
    parser.add_argument("--modes", nargs="*", default=["tracking", "global"], choices=["tracking", "global"])
    parser.add_argument("--seeds", nargs="*", type=int, default=[0])
    parser.add_argument("--ros", action="store_true", help="through the ROS nodes (bench_log_localization_ros)")
    parser.add_argument("--beside", help="another log's building on each map: its name, or `next` (the next log's)")
    parser.add_argument("--gap", type=float, default=20.0, help="--beside: m between the two buildings' maps")
    parser.add_argument("--reverse", action="store_true", help="each log played backwards (library runs only)")
    parser.add_argument("--stride", type=int, default=1, help="every stride-th scan only (library runs only)")
    args = parser.parse_args()
    if (args.reverse or args.stride != 1) and args.ros:
        parser.error("--reverse and --stride play the log in the library only")
    every = sorted(args.data.glob("*.log*"))
    names = [log_name(f) for f in every]
    files = [f for f in every if log_name(f) in args.logs] if args.logs else every
    if not files:
        print(f"no CARMEN log in {args.data}", file=sys.stderr)
        return 2
    parameters = shipped_filter_parameters()
    for path in files:
        log = thinned(read_carmen(path), args.stride)
        log = played_backwards(log) if args.reverse else log
        name = log_name(path)
        if args.beside:
            other = names[(names.index(name) + 1) % len(names)] if args.beside == "next" else args.beside
            if other == name or other not in names:
                print(f"{name}: no other log {other!r} to put beside it", file=sys.stderr)
                continue
            grid = served(log_map_beside(log, read_carmen(every[names.index(other)]), args.gap))
            name = f"{name}+{other}"
        else:
            grid = served(log_map(log))
        name += (" backwards" if args.reverse else "") + (f" 1/{args.stride}" if args.stride != 1 else "")
        for mode in args.modes:
            for seed in args.seeds:
                if args.ros:
                    from bench_log_localization_ros import run_through_ros

                    print(run_through_ros(path, log, grid, name, parameters, mode, seed), flush=True)
                else:
                    print(
                        run_log(log, name, parameters, mode, seed, grid=grid).summary() + f", seed {seed}", flush=True
                    )
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    sys.exit(main())
