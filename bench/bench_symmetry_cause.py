"""Where a particle filter loses what one symmetry-breaking feature told it (issue 20, part 1): per run, the
filter's belief in the true place against its rotated copies, followed step by step, and what changed it.

In a generated square room (amr_maps.symmetry_families) the wall follower drives the robot round while the
particle filter localizes from an unknown start, in the library closed loop. At every step the script
takes the weight of the particles near the true pose (within 0.3 m and 30 deg) and near each of its three
quarter turns about the room's centre, and their log-odds: log(mass at the truth / mass at the best
copy). It splits each step's change of that log-odds between the filter's parts by wrapping them:
the measurement update (weighting, tempered by beta), resampling with augmented-MCL injection, the rival
check's clouds before a declaration (_adopt_rivals), and, where the filter has one, the evidence ledger
(_prune_ruled_out). A feature seen and remembered shows as log-odds that grow while it is in view and stay
afterwards; a feature forgotten as log-odds that some part sends back to 0 (or below).

Prints per run and a summary per part; asserts nothing. It runs on whatever amr_localization is first on
the path (the repository it sits in), so the same script measures the filter before and after a change.
Usage: .venv/bin/python bench/bench_symmetry_cause.py [--seeds 3] [--seconds 180] [--kinds doorway notch]
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from amr_control.wall_follower_config import read_parameter_file  # noqa: E402
from amr_evaluation import configs  # noqa: E402
from amr_evaluation.closed_loop import run  # noqa: E402
from amr_evaluation.feature_watch import FeatureWatch  # noqa: E402
from amr_localization.particle_filter import ParticleFilter  # noqa: E402
from amr_localization.particle_filter_parameters import config_of  # noqa: E402
from amr_maps.rasterize import rasterize_world  # noqa: E402
from amr_maps.symmetry_families import BROKEN, FeatureView, symmetry_case  # noqa: E402
from amr_maps.world import world_from_dict  # noqa: E402
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig  # noqa: E402
from amr_simulation.simulator import Simulator  # noqa: E402
from amr_util.geometry import wrap_angle  # noqa: E402

FOLLOWER = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
PARTS = ("measure", "resample", "rivals", "ledger")


def _turns(pose) -> np.ndarray:
    x, y, theta = pose
    return np.array([[math.cos(k * math.pi / 2) * x - math.sin(k * math.pi / 2) * y,
                      math.sin(k * math.pi / 2) * x + math.cos(k * math.pi / 2) * y, theta + k * math.pi / 2]
                     for k in range(4)])


class Probe:
    """Wraps the filter's parts; each records the change of the log-odds (truth vs best copy) it made itself
    (a part called inside another, resampling inside the measurement update, is counted for itself only)."""

    def __init__(self, pf: ParticleFilter) -> None:
        self.pf, self.truth = pf, None
        self.change: dict[str, list[float]] = defaultdict(list)
        self.resets = 0  # rival clouds that brought log-odds > 2 back under 1
        self.betas: list[float] = []
        self._stack: list[float] = []
        self.said = 0.0  # what the scans said: sum of likelihood_exponent x (log p(z | truth) - best copy's)
        self.said_tempered = 0.0  # ... times each update's beta: what the weighting could keep at most
        self.said_peak = 0.0
        self.lost_truth = defaultdict(int)  # calls after which no particle was left near the truth (had some)
        for part, name in (("measure", "_measure"), ("resample", "_resample"), ("rivals", "_adopt_rivals"),
                           ("ledger", "_prune_ruled_out")):
            if hasattr(pf, name):
                setattr(pf, name, self._wrapped(part, getattr(pf, name)))

    def log_odds(self) -> float:
        if self.truth is None or not len(self.pf.particles):
            return 0.0
        masses = []
        for pose in _turns(self.truth):
            near = (np.hypot(self.pf.particles[:, 0] - pose[0], self.pf.particles[:, 1] - pose[1]) <= 0.3) & (
                np.abs(wrap_angle(self.pf.particles[:, 2] - pose[2])) <= math.radians(30.0))
            masses.append(float(self.pf.weights[near].sum()))
        return math.log(max(masses[0], 1e-12)) - math.log(max(max(masses[1:]), 1e-12))

    def _wrapped(self, part: str, method):
        def call(*args, **kwargs):
            before = self.log_odds()
            self._stack.append(0.0)
            out = method(*args, **kwargs)
            inner = self._stack.pop()
            after = self.log_odds()
            if before > -20.0 and after <= -27.0:
                self.lost_truth[part] += 1
            if part == "measure" and self.truth is not None and args and args[0] is not None \
                    and args[0].returned.any():
                scores = self.pf._laser.log_likelihood(_turns(self.truth), args[0])
                said = self.pf.config.likelihood_exponent * float(scores[0] - scores[1:].max())
                self.said += said
                self.said_tempered += self.pf.status.beta * said
                self.said_peak = max(self.said_peak, self.said)
            self.change[part].append(after - before - inner)
            if self._stack:
                self._stack[-1] += after - before
            if part == "rivals" and before > 2.0 and after < 1.0:
                self.resets += 1
            return out
        return call


def diagnose(kind: str, seed: int, seconds: float) -> dict:
    rng = np.random.default_rng([20, seed, BROKEN.index(kind)])
    noise = float(rng.uniform(0.01, 0.03)), float(rng.uniform(0.005, 0.03)), float(rng.uniform(0.01, 0.05))
    case = symmetry_case(kind, seed)
    world = world_from_dict(case.world)
    _, parameters = configs.resolve("localization", "default")
    params = {**parameters["particle_filter"], "seed": seed}
    pf = ParticleFilter(rasterize_world(world, params["map_resolution"]), config_of(params),
                        range_max=params["laser_max_range"])
    probe = Probe(pf)
    sim = Simulator(world, SimulationConfig(dt=FOLLOWER.dt, seed=seed, lidar=LidarConfig(noise_std=noise[0]),
                                            encoders=EncoderConfig(noise=noise[1], slip=noise[2])))
    watch = FeatureWatch(FeatureView(world, world_from_dict(case.symmetric)), sim.config.lidar)
    series: list[tuple[float, float, bool]] = []
    stop = watch.stop_after(5.0)

    def until(sim, estimate) -> bool:
        pose = sim.pose
        probe.truth = (pose.x, pose.y, pose.theta)
        series.append((sim.time, probe.log_odds(), estimate.localized))
        probe.betas.append(estimate.status.beta)
        return stop(sim, estimate)

    run(sim, pf, FOLLOWER, seconds, until=until)
    t = np.array([s[0] for s in series])
    odds = np.array([s[1] for s in series])
    localized = np.array([s[2] for s in series])
    first = int(np.flatnonzero(localized)[0]) if localized.any() else None
    seen = watch.seen
    out = {"name": case.world["name"], "seen": seen, "localized": t[first] if first is not None else None,
           "peak": float(odds.max()), "end": float(odds[-1]), "resets": probe.resets,
           "said": probe.said, "said_peak": probe.said_peak, "said_tempered": probe.said_tempered,
           "lost": dict(probe.lost_truth),
           "change": {part: (float(np.sum(v)), float(np.sum(np.clip(v, None, 0.0))), len(v))
                      for part, v in probe.change.items()},
           "beta": float(np.mean(probe.betas)) if probe.betas else math.nan,
           "above2": float(np.mean(odds > 2.0)), "below_minus2": float(np.mean(odds < -2.0))}
    if seen is not None:
        later = t >= seen
        out["after_seen_peak"] = float(odds[later].max()) if later.any() else math.nan
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=180.0)
    parser.add_argument("--kinds", nargs="+", default=list(BROKEN), choices=BROKEN)
    args = parser.parse_args()
    print(f"== log-odds of the true place against its best quarter turn (mass within 0.3 m / 30 deg), "
          f"{args.seconds:.0f} s at most (5 s after the first declaration with the feature seen); "
          "per part: sum of its changes, sum of its losses (changes < 0), calls")
    totals: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0])
    resets = 0
    runs = 0
    for kind in args.kinds:
        for seed in range(args.seeds):
            r = diagnose(kind, seed, args.seconds)
            runs += 1
            resets += r["resets"]
            for part, (total, lost, calls) in r["change"].items():
                totals[part][0] += total
                totals[part][1] += lost
                totals[part][2] += calls
            seen = f"{r['seen']:5.1f}" if r["seen"] is not None else "  -  "
            loc = f"{r['localized']:5.1f}" if r["localized"] is not None else "never"
            parts = "  ".join(f"{p} {v[0]:+7.1f}/{v[1]:7.1f}/{v[2]}" for p, v in sorted(r["change"].items()))
            print(f"{r['name']:18s} seen {seen} s  localized {loc}  log-odds peak {r['peak']:+6.1f} end "
                  f"{r['end']:+6.1f}  time > +2 {100 * r['above2']:4.0f} %, < -2 {100 * r['below_minus2']:4.0f} %  "
                  f"rival resets {r['resets']}  mean beta {r['beta']:.2f}  scans said {r['said']:+6.1f} (peak "
                  f"{r['said_peak']:+6.1f}, x beta {r['said_tempered']:+6.1f})  truth lost by {r['lost']}  {parts}",
                  flush=True)
    print(f"over {runs} runs: rival clouds that sent log-odds > 2 back under 1: {resets}; per part (sum of changes / "
          "sum of losses / calls): " + "  ".join(f"{p} {v[0]:+.1f}/{v[1]:.1f}/{v[2]}" for p, v in sorted(totals.items())))


if __name__ == "__main__":
    main()
