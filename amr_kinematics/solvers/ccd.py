"""Cyclic coordinate descent for planar chains (the ULL report's method, fixed).

One iteration visits the joints from the tip to the base.  A revolute joint
turns by the angle between (tip - pivot) and (target - pivot); a prismatic joint
slides by the projection of (target - tip) on its direction.  Angles are wrapped
to [-pi, pi], then every value is clamped to its limits; prismatic values are
never wrapped.  A descent stops on the tolerance, after ``max_iterations``
sweeps, or when a sweep improves the distance by less than tolerance/100 (the
report's non-convergence rule).  CCD stalls there on long chains (a folded
10-joint snake, a joint pinned on its limit), so with ``restarts`` (default) a
stalled descent starts again from a spread configuration (``starts.SpreadStarts``)
until success or the timeout; ``restarts=False`` is the report's single descent.
The closest configuration met is reported.
"""

from __future__ import annotations

import math
import time

import numpy as np

from amr_util.geometry import wrap_angle

from ..errors import SolverNotApplicableError
from . import options as opt
from .base import IKResult, IterationRecord, Solver, finish
from .starts import SpreadStarts

HYPERCUBE = 16  # restarts that share one Latin hypercube of starts


class CCDSolver(Solver):
    name = "ccd"
    options = {
        "restarts": True,
        "random_seed": 0,
        # with restarts: a sweep removing less than this fraction of the distance ends the descent
        # (CCD's tail is slow on long chains: a new start is cheaper than crawling on)
        "min_progress": 0.05,
    }

    def configure(self, settings: dict, planar: bool):
        return (
            bool(settings["restarts"]),
            opt.integer("random_seed", settings["random_seed"], low=0, high=2**63 - 1),
            opt.number("min_progress", settings["min_progress"], high=1.0),
        )

    def check(self, chain, with_orientation=False) -> None:
        if not chain.planar:
            raise SolverNotApplicableError(f"ccd works on planar chains; chain '{chain.name}' is {chain.convention}")
        if chain.couplings:
            raise SolverNotApplicableError(f"ccd cannot keep the joint couplings of chain '{chain.name}': use dls")
        if with_orientation:
            raise SolverNotApplicableError("ccd places the tip only: it takes no orientation (use dls or pinv)")

    def _solve(self, chain, goal, q0, request, configuration) -> IKResult:
        base, tool = chain.base, chain.tool
        base_xy, base_angle = base[:2, 3], math.atan2(base[1, 0], base[0, 0])
        tool_x, tool_y = tool[0, 3], tool[1, 3]
        theta, a = chain.theta.tolist(), chain.a.tolist()
        prismatic = chain.prismatic.tolist()
        lower, upper = chain.lower.tolist(), chain.upper.tolist()
        tx, ty = float(goal.position[0]), float(goal.position[1])
        n = chain.n

        def frames(q):
            """Pivot point, cumulative angle and origin of every link, and the tip."""
            x, y, angle = float(base_xy[0]), float(base_xy[1]), base_angle
            pivots, angles = [], []
            for i in range(n):
                pivots.append((x, y))
                angle += theta[i] + (0.0 if prismatic[i] else q[i])
                length = a[i] + (q[i] if prismatic[i] else 0.0)
                angles.append(angle)
                x, y = x + length * math.cos(angle), y + length * math.sin(angle)
            c, s = math.cos(angle), math.sin(angle)
            return pivots, angles, (x + c * tool_x - s * tool_y, y + s * tool_x + c * tool_y)

        history = [] if request.record_history else None
        restarts, random_seed, min_progress = configuration
        starts = SpreadStarts(chain, q0, HYPERCUBE, random_seed)
        start, iterations, attempts = q0.tolist(), 0, 0
        best_q, best_distance = start, math.inf
        while True:
            q, distance, steps, message = self._descend(
                frames,
                (lower, upper, prismatic),
                start,
                (tx, ty),
                request,
                history,
                iterations,
                min_progress if restarts else 0.0,
            )
            iterations += steps
            attempts += 1
            if distance < best_distance:
                best_q, best_distance = q, distance
            if message == "converged" or not restarts or time.perf_counter() > request.deadline:
                break
            start = starts.take(1)[0].tolist()
        if restarts and message != "converged" and attempts > 1:
            message = f"timeout: closest configuration of {attempts} descents returned"
        return finish(
            chain,
            goal,
            np.array(best_q),
            request,
            solver=self.name,
            iterations=iterations,
            message=message,
            attempts=attempts,
            history=history,
        )

    @staticmethod
    def _descend(frames, bounds, q, target, request, history, first_iteration, min_progress):
        """One CCD descent from q: (closest q, its distance, sweeps, why it stopped)."""
        n = len(q)
        (lower, upper, prismatic), (tx, ty) = bounds, target
        tip = frames(q)[2]
        distance = math.hypot(tx - tip[0], ty - tip[1])
        best_q, best_distance = list(q), distance
        message, iteration = "iteration limit reached: closest configuration returned", 0
        for iteration in range(request.max_iterations + 1):
            if history is not None:
                history.append(IterationRecord(first_iteration + iteration, np.array(q), distance, 0.0))
            if distance <= request.tolerance:
                message = "converged"
                break
            if iteration == request.max_iterations:
                break
            if time.perf_counter() > request.deadline:
                message = "timeout: closest configuration returned"
                break
            # Moving joint j leaves the pivots and angles of joints <= j as they were, so one
            # frames() per sweep suffices; the tip follows each move (turned about the pivot,
            # or slid along the joint): O(n) per sweep instead of O(n^2).
            pivots, angles, (tip_x, tip_y) = frames(q)
            for j in reversed(range(n)):
                if prismatic[j]:
                    c, s = math.cos(angles[j]), math.sin(angles[j])
                    value = min(max(q[j] + c * (tx - tip_x) + s * (ty - tip_y), lower[j]), upper[j])
                    tip_x, tip_y = tip_x + (value - q[j]) * c, tip_y + (value - q[j]) * s
                else:
                    px, py = pivots[j]
                    if math.hypot(tip_x - px, tip_y - py) < 1e-12 or math.hypot(tx - px, ty - py) < 1e-12:
                        continue  # no direction to align
                    turn = math.atan2(ty - py, tx - px) - math.atan2(tip_y - py, tip_x - px)
                    value = min(max(wrap_angle(q[j] + turn), lower[j]), upper[j])
                    c, s = math.cos(value - q[j]), math.sin(value - q[j])
                    dx, dy = tip_x - px, tip_y - py
                    tip_x, tip_y = px + c * dx - s * dy, py + s * dx + c * dy
                q[j] = value
            previous, tip = distance, frames(q)[2]
            distance = math.hypot(tx - tip[0], ty - tip[1])
            if distance < best_distance:
                best_q, best_distance = list(q), distance
            if distance > request.tolerance and abs(previous - distance) <= max(
                request.tolerance / 100.0, min_progress * previous
            ):
                iteration += 1
                if history is not None:
                    history.append(IterationRecord(first_iteration + iteration, np.array(q), distance, 0.0))
                message = "no convergence: distance improves less than tolerance/100; closest configuration returned"
                break
        return best_q, best_distance, iteration, message
