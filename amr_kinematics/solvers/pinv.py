"""Jacobian pseudo-inverse with Latin-hypercube multi-start (seed 003).

Candidates are sampled inside the joint limits by Latin hypercube (each joint's
range cut in ``samples`` strata, one sample per stratum, strata paired at
random; ``starts.latin_hypercube``), the seed is added, all are sorted by their
initial task error, and each is refined in turn with dq = gain J^+ e
(J^+ = J^T (J J^T + eps I)^-1, eps = 1e-12 m^2 by default, a guard at
singularities) and saturation at the limits.  The first to meet the tolerance
wins.  When a hypercube is used up and time is left, a new one is drawn (a step
count never ends a solve that still has time); at the timeout the best
candidate is returned.  ``samples=0`` refines the seed alone.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..transforms import rotation_error
from . import options as opt
from .base import IKResult, Solver, finish
from .iterative import COUPLING_UPDATES, Refiner, StepSettings
from .starts import SpreadStarts

MAX_SAMPLES = 10_000  # sampling and scoring 10k candidates takes ~20 ms


class PinvSolver(Solver):
    name = "pinv"
    runs_compiled = True  # the compiled attempts (compiled.py), when numba is there
    options = {
        "samples": 8,  # Latin-hypercube candidates (besides the seed)
        "gain": 0.7,  # alpha of dq = alpha J^+ e; 1.0 (the seed's) overshoots: 92-95 % full pose on unseen arms
        "candidate_iterations": 20,  # refinement steps per candidate
        "patience": 4,  # steps without 0.1 % progress before the next candidate
        "singular_guard": 1e-6,  # sqrt(eps), m: keeps J J^T + eps I invertible at singularities
        "angular_weight": None,
        "coupling_update": "reduced",
        "axis_tolerance": None,
        "random_seed": 0,
    }

    def check_task(self, chain) -> None:
        """Partial poses are rows of the same step: every chain can take them."""

    def configure(self, settings: dict, planar: bool):
        step = StepSettings(
            damping=opt.number("singular_guard", settings["singular_guard"]),
            gain=opt.number("gain", settings["gain"], high=2.0, allow_low=False),
            angular_weight=None
            if settings["angular_weight"] is None
            else opt.number("angular_weight", settings["angular_weight"]),
            coupling_update=opt.choice("coupling_update", settings["coupling_update"], COUPLING_UPDATES),
            axis_tolerance=opt.axis_tolerance(settings["axis_tolerance"], 2 if planar else 3),
            patience=opt.integer("patience", settings["patience"], low=0),
        )
        return (
            step,
            opt.integer("samples", settings["samples"], low=0, high=MAX_SAMPLES),
            opt.integer("candidate_iterations", settings["candidate_iterations"]),
            opt.integer("random_seed", settings["random_seed"], low=0, high=2**63 - 1),
        )

    def _solve(self, chain, goal, q0, request, configuration) -> IKResult:
        step, samples, per_candidate, random_seed = configuration
        refiner = Refiner(chain, goal, request, step)
        starts = SpreadStarts(chain, q0, samples, random_seed)
        steps = min(per_candidate, request.max_iterations)
        candidates = [q0] + (list(starts.draw(samples)) if samples else [])
        used, best, tried, attempt = 0, None, 0, None
        while candidates:
            for q in self._best_first(chain, goal, refiner, candidates, request.deadline):
                attempt = refiner.run(q, steps, tried)
                tried += 1
                used += attempt.iterations
                if best is None or attempt.converged or attempt.score < best.score:
                    best = attempt
                if attempt.converged or attempt.timed_out or time.perf_counter() > request.deadline:
                    break
            out_of_time = attempt.timed_out or time.perf_counter() > request.deadline
            candidates = [] if best.converged or out_of_time or not samples else list(starts.draw(samples))
        if best.converged:
            message = f"converged from candidate {tried}"
        elif samples:
            message = f"timeout: best of {tried} candidates returned"
        else:
            message = "the seed alone did not meet the tolerance (samples=0): best returned"
        return finish(
            chain,
            goal,
            best.q,
            request,
            solver=self.name,
            iterations=used,
            message=message,
            attempts=tried,
            history=refiner.history,
            converged=best.converged,
        )

    def _best_first(self, chain, goal, refiner, candidates, deadline) -> list:
        """Candidates sorted by initial task error (scoring many takes time: keep to the deadline)."""
        errors = []
        for q in candidates:
            errors.append(self._initial_error(chain, goal, refiner, q))
            if len(errors) % 64 == 0 and time.perf_counter() > deadline:
                break
        return [candidates[i] for i in np.argsort(errors, kind="stable")]

    @staticmethod
    def _initial_error(chain, goal, refiner, q) -> float:
        """Weighted task error norm at q, the key candidates are sorted by (hypot: no overflow on far targets)."""
        if goal.task is not None:
            return math.sqrt(refiner.score(q))
        pose = chain.kernel.pose(q.tolist())
        dp = goal.position - pose[:3]
        terms = [dp[0], dp[1]] if chain.planar else [dp[0], dp[1], dp[2]]
        if goal.rotation is not None:
            w = rotation_error(*pose[3:12], *goal.rotation.ravel())
            terms += [refiner.angular_weight * w[i] for i in ((2,) if chain.planar else (0, 1, 2))]
        score = math.hypot(*terms)
        return score if math.isfinite(score) else math.inf
