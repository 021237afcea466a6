"""IK solve time and success over random reachable targets, ours and the peers'.

    python bench/bench_ik.py [--targets 10000] [--peer-targets 1000] [--chains ur5 panda]
                             [--no-peers] [--profile ur5:dls:pose]

Targets are FK of uniformly random in-limit configurations (coupled joints
derived, and within their limits), the same for every solver of a chain; every solve starts from the
chain's ``home``.  Success is checked here, the same way for everyone: position
error <= 1e-5 m (x, y for planar chains), orientation error <= 1e-5 rad in pose
mode, joints within limits.  Our solvers run with the library defaults and a 5 ms
timeout (``--timeout``); ikpy (scipy optimiser) and roboticstoolbox-python
(C++ ``ik_LM``) run with their defaults on the first ``--peer-targets`` targets.
Times are wall-clock per solve call (perf_counter), request checks included;
``cpu_mean_us`` is the thread's CPU time per call, which other processes on a
busy machine do not inflate as much (the load average is printed before and after).
"""

from __future__ import annotations

import argparse
import cProfile
import os
import platform
import pstats
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from amr_kinematics.config import load_chain_set  # noqa: E402
from amr_kinematics.solvers import applicable_solvers, get_solver  # noqa: E402
from ik_peers import angle_between, peers  # noqa: E402

TOLERANCE = 1e-5
PEER_CHAINS = ("ur5", "panda")


def make_targets(chain, count: int, rng: np.random.Generator) -> list[np.ndarray]:
    """Tool poses of random in-limit configurations; with couplings, only those whose
    coupled joints need no clipping (others are not configurations of the coupled arm)."""
    targets = []
    while len(targets) < count:
        q = chain.apply_coupling(rng.uniform(chain.lower, chain.upper))
        if chain.couplings_hold(q):
            targets.append(chain.fk(q).tool)
    return targets


def succeeded(chain, q, target: np.ndarray, with_orientation: bool) -> bool:
    q = np.asarray(q, dtype=float)
    if q.shape != (chain.n,) or not np.all(np.isfinite(q)) or not chain.within_limits(q, 1e-9):
        return False
    reached = chain.fk(q).tool
    dims = 2 if chain.planar else 3
    if np.linalg.norm(reached[:dims, 3] - target[:dims, 3]) > TOLERANCE:
        return False
    return not with_orientation or angle_between(reached[:3, :3], target[:3, :3]) <= TOLERANCE


def run_ours(config, solver: str, targets, with_orientation: bool, timeout: float):
    chain, solve = config.chain, get_solver(solver).solve
    times, cpu, ok = [], [], 0
    for target in targets:
        goal = target if with_orientation else target[:3, 3].copy()
        started, started_cpu = time.perf_counter(), time.thread_time()
        result = solve(chain, goal, seed=config.home, with_orientation=with_orientation, tolerance=TOLERANCE,
                       timeout=timeout)
        times.append(time.perf_counter() - started)
        cpu.append(time.thread_time() - started_cpu)
        ok += succeeded(chain, result.q, target, with_orientation)
    return ok, np.array(times), np.array(cpu)


def run_peer(peer, config, targets, with_orientation: bool):
    times, cpu, ok = [], [], 0
    for target in targets:
        started, started_cpu = time.perf_counter(), time.thread_time()
        try:
            q = peer.solve(target, config.home, with_orientation)
        except Exception:  # noqa: BLE001 - a peer's failure is a failed solve
            q = None
        times.append(time.perf_counter() - started)
        cpu.append(time.thread_time() - started_cpu)
        ok += q is not None and succeeded(config.chain, q, target, with_orientation)
    return ok, np.array(times), np.array(cpu)


def row(chain: str, solver: str, mode: str, ok: int, times: np.ndarray, cpu: np.ndarray) -> dict:
    us = times * 1e6
    return {"chain": chain, "solver": solver, "mode": mode, "n": len(times), "success": 100.0 * ok / len(times),
            "median": float(np.median(us)), "p99": float(np.percentile(us, 99)), "mean": float(us.mean()),
            "cpu": float(cpu.mean() * 1e6)}


def print_row(r: dict) -> None:
    print(f"{r['chain']:<13} {r['solver']:<9} {r['mode']:<9} {r['n']:>6} {r['success']:>8.2f} "
          f"{r['median']:>10.1f} {r['p99']:>10.1f} {r['mean']:>10.1f} {r['cpu']:>11.1f}", flush=True)


def load() -> str:
    return "load average " + ", ".join(f"{x:.2f}" for x in os.getloadavg()) + f" on {os.cpu_count()} CPUs"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--targets", type=int, default=10_000)
    parser.add_argument("--peer-targets", type=int, default=1000, help="targets for ikpy and rtb (ikpy takes ms each)")
    parser.add_argument("--chains", nargs="*", help="chain names (default: all in config/ik_chains.yaml)")
    parser.add_argument("--timeout", type=float, default=0.005, help="per-solve budget of our solvers, s")
    parser.add_argument("--no-peers", action="store_true")
    parser.add_argument("--seed", type=int, default=2024)
    parser.add_argument("--profile", metavar="CHAIN:SOLVER:MODE", help="cProfile one case instead of the table")
    args = parser.parse_args()

    configs = load_chain_set(yaml.safe_load((ROOT / "config" / "ik_chains.yaml").read_text()))
    names = args.chains or list(configs)
    rng = np.random.default_rng(args.seed)
    targets = {name: make_targets(configs[name].chain, args.targets, rng) for name in names}

    if args.profile:
        chain, solver, mode = args.profile.split(":")
        profile = cProfile.Profile()
        profile.runcall(run_ours, configs[chain], solver, targets[chain], mode == "pose", args.timeout)
        pstats.Stats(profile).sort_stats("tottime").print_stats(20)
        return

    available, missing = ({}, {}) if args.no_peers else peers()
    print(f"# Python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, "
          f"tolerance {TOLERANCE:g} m / rad, our timeout {args.timeout * 1e3:g} ms, seed = chain home")
    print(f"# {load()} (start)")
    for name, reason in missing.items():
        print(f"# {name} not available: {reason}")
    print(f"{'chain':<13} {'solver':<9} {'mode':<9} {'n':>6} {'success%':>8} {'median_us':>10} {'p99_us':>10} "
          f"{'mean_us':>10} {'cpu_mean_us':>11}")
    rows = []
    for name in names:
        config = configs[name]
        modes = [False] + ([True] if config.chain.can_orient and not config.chain.planar else [])
        for with_orientation in modes:
            mode = "pose" if with_orientation else "position"
            for solver in applicable_solvers(config.chain, with_orientation):
                rows.append(row(name, solver, mode, *run_ours(config, solver, targets[name], with_orientation,
                                                              args.timeout)))
                print_row(rows[-1])
            if name not in PEER_CHAINS:
                continue
            subset = targets[name][: args.peer_targets]
            for peer_name, factory in available.items():
                rows.append(row(name, peer_name, mode, *run_peer(factory(config.chain), config, subset,
                                                                 with_orientation)))
                print_row(rows[-1])
    print_speedups(rows)
    print(f"# {load()} (end)")


def print_speedups(rows: list[dict]) -> None:
    """Mean time of each peer over our dls's, same chain and mode."""
    ours = {(r["chain"], r["mode"]): r for r in rows if r["solver"] == "dls"}
    lines = []
    for r in rows:
        if r["solver"] in ("ikpy", "rtb") and (r["chain"], r["mode"]) in ours:
            mine = ours[(r["chain"], r["mode"])]
            lines.append(f"#   {r['chain']:<6} {r['mode']:<9} {r['solver']:<5} mean / dls mean = "
                         f"{r['mean'] / mine['mean']:.1f}x, median / dls median = {r['median'] / mine['median']:.1f}x")
    if lines:
        print("# peer time over ours (> 1: ours faster)")
        print("\n".join(lines))


if __name__ == "__main__":
    main()
