"""Cyclic coordinate descent for planar chains (the ULL report's method, fixed).

One iteration visits the joints from the tip to the base.  A revolute joint
turns by the angle between (tip - pivot) and (target - pivot); a prismatic joint
slides by the projection of (target - tip) on its direction.  Angles are wrapped
to [-pi, pi], then every value is clamped to its limits; prismatic values are
never wrapped.  The loop stops on the tolerance, on the iteration limit, on the
timeout, or when an iteration improves the distance by less than tolerance/100
(the report's non-convergence rule): the closest configuration met is reported.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..errors import SolverNotApplicableError
from ..transforms import wrap_angle
from .base import IKResult, IterationRecord, Solver, finish


class CCDSolver(Solver):
    name = "ccd"
    options = {}

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

        q = q0.tolist()
        history = [] if request.record_history else None
        tip = frames(q)[2]
        distance = math.hypot(tx - tip[0], ty - tip[1])
        best_q, best_distance = list(q), distance
        message, iteration = "iteration limit reached: closest configuration returned", 0
        for iteration in range(request.max_iterations + 1):
            if history is not None:
                history.append(IterationRecord(iteration, np.array(q), distance, 0.0))
            if distance <= request.tolerance:
                message = "converged"
                break
            if iteration == request.max_iterations:
                break
            if time.perf_counter() > request.deadline:
                message = "timeout: closest configuration returned"
                break
            for j in reversed(range(n)):
                pivots, angles, tip = frames(q)
                if prismatic[j]:
                    value = q[j] + math.cos(angles[j]) * (tx - tip[0]) + math.sin(angles[j]) * (ty - tip[1])
                else:
                    px, py = pivots[j]
                    if math.hypot(tip[0] - px, tip[1] - py) < 1e-12 or math.hypot(tx - px, ty - py) < 1e-12:
                        continue  # no direction to align
                    turn = math.atan2(ty - py, tx - px) - math.atan2(tip[1] - py, tip[0] - px)
                    value = wrap_angle(q[j] + turn)
                q[j] = min(max(value, lower[j]), upper[j])
            previous, tip = distance, frames(q)[2]
            distance = math.hypot(tx - tip[0], ty - tip[1])
            if distance < best_distance:
                best_q, best_distance = list(q), distance
            if distance > request.tolerance and abs(previous - distance) <= request.tolerance / 100.0:
                iteration += 1
                if history is not None:
                    history.append(IterationRecord(iteration, np.array(q), distance, 0.0))
                message = "no convergence: distance improves less than tolerance/100; closest configuration returned"
                break
        return finish(chain, goal, np.array(best_q), request, solver=self.name, iterations=iteration,
                      message=message, history=history)
