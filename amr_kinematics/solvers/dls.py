"""Damped least squares (seed 004) with restarts until the time budget is spent.

The first attempt starts from the seed, so a solve near the previous solution
stays near it.  When an attempt stalls (``patience`` steps without progress) or
uses up its steps (``attempt_iterations``, at most ``max_iterations``), a new one
starts from the closest of ``restart_candidates`` spread configurations
(``starts.SpreadStarts``: Latin-hypercube batches), until success or the
timeout: a step count never ends a solve that still has time.  The best
configuration found is returned.  ``restarts=False`` gives the plain method of
the seed: one attempt of at most ``max_iterations`` steps.
"""

from __future__ import annotations

import time

from . import options as opt
from .base import IKResult, Solver, finish
from .iterative import COUPLING_UPDATES, Refiner, StepSettings, measured_attempt, measured_result
from .starts import SpreadStarts

BATCHES_PER_HYPERCUBE = 8  # restarts that share one Latin hypercube of starts


class DLSSolver(Solver):
    name = "dls"
    runs_compiled = True  # the compiled attempts (compiled.py), when numba is there
    options = {
        "damping": 1e-3,  # lambda-bar, m
        "adaptive_damping": 0.1,  # lambda^2 = damping^2 + adaptive_damping |e|^2 (0: constant)
        "angular_weight": None,  # m/rad of rotation rows; see iterative.StepSettings
        "coupling_update": "reduced",
        "axis_tolerance": None,  # per-axis position bounds (m) instead of the norm
        "restarts": True,
        "attempt_iterations": 30,  # steps per attempt before a restart
        "patience": 5,  # steps without 0.1 % progress before a restart
        "restart_candidates": 8,  # spread configurations per restart; the closest to the goal is used
        "random_seed": 0,  # restarts are reproducible
    }

    def check_task(self, chain) -> None:
        """Partial poses are rows of the same step: every chain can take them."""

    def configure(self, settings: dict, planar: bool):
        restarts = bool(settings["restarts"])
        step = StepSettings(
            damping=opt.number("damping", settings["damping"]),
            adaptive_damping=opt.number("adaptive_damping", settings["adaptive_damping"]),
            angular_weight=None
            if settings["angular_weight"] is None
            else opt.number("angular_weight", settings["angular_weight"]),
            coupling_update=opt.choice("coupling_update", settings["coupling_update"], COUPLING_UPDATES),
            axis_tolerance=opt.axis_tolerance(settings["axis_tolerance"], 2 if planar else 3),
            patience=opt.integer("patience", settings["patience"], low=0) if restarts else 0,
        )
        if step.damping == 0.0 and step.adaptive_damping == 0.0:
            raise opt.InvalidRequestError("dls needs damping > 0 or adaptive_damping > 0 (else it is 'pinv')")
        return (
            step,
            restarts,
            opt.integer("attempt_iterations", settings["attempt_iterations"]),
            opt.integer("random_seed", settings["random_seed"], low=0, high=2**63 - 1),
            opt.integer("restart_candidates", settings["restart_candidates"], high=1000),
        )

    def _solve(self, chain, goal, q0, request, configuration) -> IKResult:
        step, restarts, attempt_iterations, random_seed, restart_candidates = configuration
        steps = min(attempt_iterations, request.max_iterations) if restarts else request.max_iterations
        q, used, attempts, best = q0, 0, 0, None
        first = measured_attempt(chain, goal, request, step, q0, steps)
        if first is not None:  # the first attempt and its measures in one compiled call
            best, out = first
            used, attempts = best.iterations, 1
            if best.converged or not restarts or time.perf_counter() > request.deadline:
                return measured_result(
                    chain, out, best, solver=self.name, message=_message(best, best, 1, used, restarts, request)
                )
        refiner = Refiner(chain, goal, request, step)
        starts = SpreadStarts(chain, q0, restart_candidates * BATCHES_PER_HYPERCUBE, random_seed)
        if first is not None:
            q = refiner.closest(starts.take(restart_candidates))
        while True:
            attempt = refiner.run(q, steps, attempts)
            attempts += 1
            used += attempt.iterations
            if best is None or attempt.converged or attempt.score < best.score:
                best = attempt
            if attempt.converged or attempt.timed_out or not restarts or time.perf_counter() > request.deadline:
                break
            q = refiner.closest(starts.take(restart_candidates))
        return finish(
            chain,
            goal,
            best.q,
            request,
            solver=self.name,
            iterations=used,
            message=_message(best, attempt, attempts, used, restarts, request),
            attempts=attempts,
            history=refiner.history,
            converged=best.converged,
        )


def _message(best, last, attempts: int, used: int, restarts: bool, request) -> str:
    """How a solve ended, from its best and its last attempt."""
    if best.converged:
        return "converged" + (f" after {attempts - 1} restart(s)" if attempts > 1 else "")
    if restarts:
        return f"timeout: best configuration of {attempts} attempt(s) returned"
    if used >= request.max_iterations:
        return "iteration limit reached: best configuration found returned"
    if last.timed_out:
        return "timeout: best configuration found returned"
    return "stalled (no progress): best configuration found returned; target may be out of reach"
