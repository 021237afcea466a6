"""Damped least squares (seed 004) with random restarts inside the time budget.

The first attempt starts from the seed, so a solve near the previous solution
stays near it.  When an attempt stalls (``patience`` steps without progress) or
uses up ``attempt_iterations``, a new one starts from a uniformly random
configuration, until success, ``max_iterations`` in total or the timeout (the
best configuration found is returned).  ``restarts=False`` gives the plain
method of the seed: one attempt, run until it converges or the limits hit.
"""

from __future__ import annotations

import numpy as np

from . import options as opt
from .base import IKResult, Solver, finish
from .iterative import COUPLING_UPDATES, Refiner, StepSettings


class DLSSolver(Solver):
    name = "dls"
    options = {
        "damping": 1e-3,             # lambda-bar, m
        "adaptive_damping": 0.1,     # lambda^2 = damping^2 + adaptive_damping |e|^2 (0: constant)
        "angular_weight": None,      # m/rad of rotation rows; see iterative.StepSettings
        "coupling_update": "reduced",
        "axis_tolerance": None,      # per-axis position bounds (m) instead of the norm
        "restarts": True,
        "attempt_iterations": 30,    # steps per attempt before a restart
        "patience": 5,               # steps without 0.1 % progress before a restart
        "restart_candidates": 8,     # random configurations drawn per restart; the closest to the goal is used
        "random_seed": 0,            # restarts are reproducible
    }

    def configure(self, settings: dict, planar: bool):
        restarts = bool(settings["restarts"])
        step = StepSettings(
            damping=opt.number("damping", settings["damping"]),
            adaptive_damping=opt.number("adaptive_damping", settings["adaptive_damping"]),
            angular_weight=None if settings["angular_weight"] is None else opt.number("angular_weight", settings["angular_weight"]),
            coupling_update=opt.choice("coupling_update", settings["coupling_update"], COUPLING_UPDATES),
            axis_tolerance=opt.axis_tolerance(settings["axis_tolerance"], 2 if planar else 3),
            patience=opt.integer("patience", settings["patience"], low=0) if restarts else 0,
        )
        if step.damping == 0.0 and step.adaptive_damping == 0.0:
            raise opt.InvalidRequestError("dls needs damping > 0 or adaptive_damping > 0 (else it is 'pinv')")
        return (step, restarts, opt.integer("attempt_iterations", settings["attempt_iterations"]),
                opt.integer("random_seed", settings["random_seed"], low=0, high=2**63 - 1),
                opt.integer("restart_candidates", settings["restart_candidates"], high=1000))

    def _solve(self, chain, goal, q0, request, configuration) -> IKResult:
        step, restarts, attempt_iterations, random_seed, restart_candidates = configuration
        rng = None  # made on the first restart: creating a generator costs ~10 us
        refiner = Refiner(chain, goal, request, step)
        q, used, attempts, best = q0, 0, 0, None
        while True:
            budget = request.max_iterations - used
            attempt = refiner.run(q, min(budget, attempt_iterations) if restarts else budget, attempts)
            attempts += 1
            used += attempt.iterations
            if best is None or attempt.converged or attempt.score < best.score:
                best = attempt
            if attempt.converged or attempt.timed_out or not restarts or used >= request.max_iterations:
                break
            rng = rng or np.random.default_rng(random_seed)
            q = self._restart(chain, refiner, rng, restart_candidates)
        if best.converged:
            message = "converged" + (f" after {attempts - 1} restart(s)" if attempts > 1 else "")
        elif best.timed_out or attempt.timed_out:
            message = "timeout: best configuration found returned"
        elif used >= request.max_iterations:
            message = "iteration limit reached: best configuration found returned"
        else:
            message = "stalled (no progress): best configuration found returned; target may be out of reach"
        return finish(chain, goal, best.q, request, solver=self.name, iterations=used, message=message,
                      attempts=attempts, history=refiner.history, converged=best.converged)

    @staticmethod
    def _restart(chain, refiner, rng, candidates: int) -> np.ndarray:
        """A uniformly random configuration; with several candidates, the closest one."""
        if candidates == 1:
            return chain.apply_coupling(rng.uniform(chain.lower, chain.upper))
        draws = [chain.apply_coupling(q) for q in rng.uniform(chain.lower, chain.upper, size=(candidates, chain.n))]
        return min(draws, key=refiner.score)
