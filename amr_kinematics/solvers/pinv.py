"""Jacobian pseudo-inverse with Latin-hypercube multi-start (seed 003).

Candidates are sampled inside the joint limits by Latin hypercube (each joint's
range cut in ``samples`` strata, one sample per stratum, strata paired at
random), the seed is added, all are sorted by their initial task error, and each
is refined in turn with dq = gain J^+ e (J^+ = J^T (J J^T + eps I)^-1, eps = 1e-12 m^2
by default, a guard at singularities) and saturation at the limits.  The first to meet the
tolerance wins; else the best one is returned.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..transforms import rotation_error
from . import options as opt
from .base import IKResult, Solver, finish
from .iterative import COUPLING_UPDATES, Refiner, StepSettings


def latin_hypercube(rng: np.random.Generator, lower: np.ndarray, upper: np.ndarray, samples: int) -> np.ndarray:
    """(samples, dims) points: every dimension has one point in each of its strata."""
    dims = lower.size
    strata = rng.permuted(np.tile(np.arange(samples), (dims, 1)), axis=1)
    unit = (strata + rng.random((dims, samples))) / samples
    return (lower[:, None] + (upper - lower)[:, None] * unit).T


MAX_SAMPLES = 10_000  # sampling and scoring 10k candidates takes ~20 ms


class PinvSolver(Solver):
    name = "pinv"
    options = {
        "samples": 8,                  # Latin-hypercube candidates (besides the seed)
        "gain": 1.0,                   # alpha of the seed; < 1 is slower but steadier
        "candidate_iterations": 20,    # refinement steps per candidate
        "patience": 4,                 # steps without 0.1 % progress before the next candidate
        "singular_guard": 1e-6,        # sqrt(eps), m: keeps J J^T + eps I invertible at singularities
        "angular_weight": None,
        "coupling_update": "reduced",
        "axis_tolerance": None,
        "random_seed": 0,
    }

    def configure(self, settings: dict, planar: bool):
        step = StepSettings(
            damping=opt.number("singular_guard", settings["singular_guard"]),
            gain=opt.number("gain", settings["gain"], high=2.0, allow_low=False),
            angular_weight=None if settings["angular_weight"] is None else opt.number("angular_weight", settings["angular_weight"]),
            coupling_update=opt.choice("coupling_update", settings["coupling_update"], COUPLING_UPDATES),
            axis_tolerance=opt.axis_tolerance(settings["axis_tolerance"], 2 if planar else 3),
            patience=opt.integer("patience", settings["patience"], low=0),
        )
        return (step, opt.integer("samples", settings["samples"], low=0, high=MAX_SAMPLES),
                opt.integer("candidate_iterations", settings["candidate_iterations"]),
                opt.integer("random_seed", settings["random_seed"], low=0, high=2**63 - 1))

    def _solve(self, chain, goal, q0, request, configuration) -> IKResult:
        step, samples, per_candidate, random_seed = configuration
        rng = np.random.default_rng(random_seed)
        refiner = Refiner(chain, goal, request, step)
        candidates = [q0]
        if samples:
            free = chain.free
            for point in latin_hypercube(rng, chain.lower[free], chain.upper[free], samples):
                q = q0.copy()
                q[free] = point
                candidates.append(chain.apply_coupling(q))
        errors = []
        for q in candidates:  # scoring many candidates takes time: keep to the deadline
            errors.append(self._initial_error(chain, goal, refiner, q))
            if len(errors) % 64 == 0 and time.perf_counter() > request.deadline:
                break
        order = np.argsort(errors, kind="stable")
        used, best, tried = 0, None, 0
        for index in order:
            attempt = refiner.run(candidates[index], min(per_candidate, request.max_iterations - used), tried)
            tried += 1
            used += attempt.iterations
            if best is None or attempt.converged or attempt.score < best.score:
                best = attempt
            if attempt.converged or attempt.timed_out or used >= request.max_iterations:
                break
        if best.converged:
            message = f"converged from candidate {tried} of {len(candidates)}"
        elif attempt.timed_out:
            message = "timeout: best candidate returned"
        else:
            message = f"no candidate met the tolerance ({tried} tried): best returned"
        return finish(chain, goal, best.q, request, solver=self.name, iterations=used, message=message,
                      attempts=tried, history=refiner.history, converged=best.converged)

    @staticmethod
    def _initial_error(chain, goal, refiner, q) -> float:
        """Weighted task error norm at q, the key candidates are sorted by (hypot: no overflow on far targets)."""
        pose = chain.kernel.pose(q.tolist())
        dp = goal.position - pose[:3]
        terms = [dp[0], dp[1]] if chain.planar else [dp[0], dp[1], dp[2]]
        if goal.rotation is not None:
            w = rotation_error(*pose[3:12], *goal.rotation.ravel())
            terms += [refiner.angular_weight * w[i] for i in ((2,) if chain.planar else (0, 1, 2))]
        score = math.hypot(*terms)
        return score if math.isfinite(score) else math.inf
