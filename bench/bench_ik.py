"""IK solve time and success over random reachable targets, ours and the peers'.

    python bench/bench_ik.py [--targets 10000] [--peer-targets 1000] [--chains ur5 panda]
                             [--solvers dls] [--no-peers] [--profile ur5:dls:pose]

Chains: the shipped ones (config/ik_chains.yaml) and industrial arms the solvers were
not tuned on (bench/ik_unseen_chains.yaml).

Targets are FK of uniformly random in-limit configurations (coupled joints
derived, and within their limits), the same for every solver of a chain; every solve starts from the
chain's ``home``; two untimed solves (``warm_up``) go first, as the IK node warms up at
configure (numba loads each compiled function at its first call).  Success is checked here, the same way for
everyone: position error <= 1e-5 m (x, y for planar chains), orientation error <= 1e-5 rad in pose
mode, joints within limits.  Our solvers run with the library defaults and a 5 ms
timeout (``--timeout``); ikpy (scipy optimiser) and roboticstoolbox-python
(C++ ``ik_LM``) run with their defaults on the first ``--peer-targets`` targets.
Times are wall-clock per solve call (perf_counter), request checks included;
``cpu_mean_us`` is the thread's CPU time per call, which other processes on a
busy machine do not inflate as much (the load average is printed before and after).  Objects
that exist before the timed runs are frozen out of garbage collection (``gc.freeze``): a full
collection of the imported libraries' objects takes 40-50 ms and fell on one solve or another.
"""

from __future__ import annotations

import argparse
import cProfile
import gc
import math
import os
import platform
import pstats
import time
from pathlib import Path

import numpy as np
import yaml
from ik_peers import angle_between, peers

from amr_kinematics.config import load_chain_set
from amr_kinematics.solvers import applicable_solvers, get_solver

ROOT = Path(__file__).resolve().parents[1]

TOLERANCE = 1e-5
CHAIN_FILES = (ROOT / "config" / "ik_chains.yaml", Path(__file__).resolve().parent / "ik_unseen_chains.yaml")


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
    warm_up(config, solve, targets[0], with_orientation, timeout)
    times, cpu, iterations, ok = [], [], [], 0
    for target in targets:
        goal = target if with_orientation else target[:3, 3].copy()
        started, started_cpu = time.perf_counter(), time.thread_time()
        result = solve(
            chain, goal, seed=config.home, with_orientation=with_orientation, tolerance=TOLERANCE, timeout=timeout
        )
        times.append(time.perf_counter() - started)
        cpu.append(time.thread_time() - started_cpu)
        iterations.append(result.iterations)
        ok += succeeded(chain, result.q, target, with_orientation)
    return ok, np.array(times), np.array(cpu), np.array(iterations, dtype=float)


def warm_up(config, solve, target: np.ndarray, with_orientation: bool, timeout: float) -> None:
    """Untimed solves down the paths the timed ones take (a reachable target, then an unreachable
    one, which restarts), as the IK node's warm-up at configure does for its configured options:
    numba loads each compiled function at its first call (~0.3 s)."""
    far = target.copy()
    far[:3, 3] += 1e3
    for goal in (target, far):
        solve(
            config.chain,
            goal if with_orientation else goal[:3, 3].copy(),
            seed=config.home,
            with_orientation=with_orientation,
            tolerance=TOLERANCE,
            timeout=timeout,
        )


def run_peer(peer, config, targets, with_orientation: bool):
    times, cpu, iterations, ok = [], [], [], 0
    for target in targets:
        started, started_cpu = time.perf_counter(), time.thread_time()
        try:
            q, steps = peer.solve(target, config.home, with_orientation)
        except Exception:  # a peer's failure is a failed solve
            q, steps = None, math.nan
        times.append(time.perf_counter() - started)
        cpu.append(time.thread_time() - started_cpu)
        iterations.append(steps)
        ok += q is not None and succeeded(config.chain, q, target, with_orientation)
    return ok, np.array(times), np.array(cpu), np.array(iterations, dtype=float)


def row(chain: str, solver: str, mode: str, ok: int, times: np.ndarray, cpu: np.ndarray, iterations) -> dict:
    us = times * 1e6
    return {
        "chain": chain,
        "solver": solver,
        "mode": mode,
        "n": len(times),
        "success": 100.0 * ok / len(times),
        "median": float(np.median(us)),
        "p99": float(np.percentile(us, 99)),
        "mean": float(us.mean()),
        "cpu": float(cpu.mean() * 1e6),
        "iterations": float(np.mean(iterations)),
    }


def print_row(r: dict) -> None:
    print(
        f"{r['chain']:<13} {r['solver']:<9} {r['mode']:<9} {r['n']:>6} {r['success']:>8.2f} "
        f"{r['median']:>10.1f} {r['p99']:>10.1f} {r['mean']:>10.1f} {r['cpu']:>11.1f} {r['iterations']:>7.1f}",
        flush=True,
    )


def load() -> str:
    return "load average " + ", ".join(f"{x:.2f}" for x in os.getloadavg()) + f" on {os.cpu_count()} CPUs"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--targets", type=int, default=10_000)
    parser.add_argument("--peer-targets", type=int, default=1000, help="targets for ikpy and rtb (ikpy takes ms each)")
    parser.add_argument("--chains", nargs="*", help="chain names (default: all in config/ik_chains.yaml)")
    parser.add_argument("--timeout", type=float, default=0.005, help="per-solve budget of our solvers, s")
    parser.add_argument("--solvers", nargs="*", help="our solvers (default: every applicable one)")
    parser.add_argument("--no-peers", action="store_true")
    parser.add_argument("--peers", nargs="*", help="peer names (default: all that import: ikpy rtb_LM rtb_NR)")
    parser.add_argument("--seed", type=int, default=2024)
    parser.add_argument("--profile", metavar="CHAIN:SOLVER:MODE", help="cProfile one case instead of the table")
    args = parser.parse_args()

    configs = {}
    for path in CHAIN_FILES:
        configs.update(load_chain_set(yaml.safe_load(path.read_text())))
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
    if args.peers:
        available = {name: factory for name, factory in available.items() if name in args.peers}
    print(
        f"# Python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, "
        f"tolerance {TOLERANCE:g} m / rad, our timeout {args.timeout * 1e3:g} ms, seed = chain home"
    )
    print(f"# {load()} (start)")
    for name, reason in missing.items():
        print(f"# {name} not available: {reason}")
    # the imports (roboticstoolbox, sympy, numba) leave ~240,000 objects that a full collection walks in
    # 40-50 ms, landing on whichever solve, ours or a peer's, triggers it: keep them out of collections
    gc.collect()
    gc.freeze()
    print(
        f"{'chain':<13} {'solver':<9} {'mode':<9} {'n':>6} {'success%':>8} {'median_us':>10} {'p99_us':>10} "
        f"{'mean_us':>10} {'cpu_mean_us':>11} {'iters':>7}"
    )
    rows = []
    for name in names:
        config = configs[name]
        modes = [False] + ([True] if config.chain.can_orient else [])
        for with_orientation in modes:
            mode = "pose" if with_orientation else "position"
            for solver in applicable_solvers(config.chain, with_orientation):
                if args.solvers and solver not in args.solvers:
                    continue
                rows.append(
                    row(name, solver, mode, *run_ours(config, solver, targets[name], with_orientation, args.timeout))
                )
                print_row(rows[-1])
            subset = targets[name][: args.peer_targets]
            for peer_name, factory in available.items():
                try:
                    peer = factory(config.chain)
                except (NotImplementedError, RuntimeError) as exc:
                    print(f"# {peer_name} cannot model {name}: {exc}")
                    continue
                if mode not in getattr(peer, "modes", (mode,)):
                    continue
                rows.append(row(name, peer_name, mode, *run_peer(peer, config, subset, with_orientation)))
                print_row(rows[-1])
    print_speedups(rows)
    print(f"# {load()} (end)")


def print_speedups(rows: list[dict]) -> None:
    """Each peer's median and mean over our dls's, same chain and mode (> 1: ours faster)."""
    ours = {(r["chain"], r["mode"]): r for r in rows if r["solver"] == "dls"}
    lines = []
    for r in rows:
        if r["solver"] in ("ikpy", "rtb_LM", "rtb_NR", "tracik") and (r["chain"], r["mode"]) in ours:
            mine = ours[(r["chain"], r["mode"])]
            lines.append(
                f"#   {r['chain']:<12} {r['mode']:<9} {r['solver']:<7} median ratio "
                f"{r['median'] / mine['median']:6.2f}x, mean ratio {r['mean'] / mine['mean']:6.2f}x, "
                f"success {r['success']:.2f} % vs ours {mine['success']:.2f} %"
            )
    if lines:
        print("# peer time over our dls time (> 1: ours faster)")
        print("\n".join(lines))


if __name__ == "__main__":
    main()
