"""Damped least-squares refinement from one start: the engine of 'dls' and 'pinv'.

One step (seed 004, Buss & Kim; Sugihara's error-dependent damping as option):

    e   = task error (position rows, then angular_weight * rotation vector rows)
    l^2 = damping^2 + adaptive_damping * |e|^2
    dq  = gain * J^T (J J^T + l^2 I)^-1 e

then joints are kept in their limits: a revolute joint that leaves its range is
first moved by 2 pi if that brings it back (same pose); joints that still leave
it are set on their limit and the others solve again for the error left,
e' = e - J_s (q_limit - q)_s with the saturated columns removed (one pass of
Baerlocher & Boulic's clamping loop).  Prismatic values are never wrapped.

Coupled joints (q_k = offset + c . q) follow one of two updates:
``reduced`` steps the independent joints with the chain-rule Jacobian
J_r = J_free + J_k c_free; ``project`` (seed 004) steps all joints as if free and
then overwrites the coupled ones.

Speed: short attempts (position, full pose, weighted rotation rows, both coupling
updates) run compiled (compiled.py; ``measured_attempt`` also measures the result
in the same call).  Without numba, position-only goals (reduced couplings) run on
scalar floats with a closed-form 3x3 solve, spatial full-pose goals without
couplings on floats with numpy only for the 6x6 solve; per-axis tolerances,
partial poses, recorded histories and the rest take the generic numpy loop.  All
follow the same equations (checked against each other in tests).  Solvers keep no state between
solves, so threads may share them (they interleave under the GIL).
"""

from __future__ import annotations

import math
import time
import weakref
from dataclasses import dataclass
from operator import le, mul

import numpy as np

from ..chain import Chain
from ..transforms import rotation_error
from . import compiled
from .base import Goal, IKResult, IterationRecord, Request
from .task import task_rows

try:  # the gufunc behind np.linalg.solve, without its ~3 us of Python-level checks
    from numpy.linalg._umath_linalg import solve1 as _solve
except ImportError:  # pragma: no cover - other numpy layouts
    _solve = np.linalg.solve

TWO_PI = 2.0 * math.pi
_EYE3 = np.eye(3)
COUPLING_UPDATES = ("reduced", "project")


@dataclass(frozen=True)
class StepSettings:
    """Parameters of the DLS step (see the module docstring)."""

    damping: float
    adaptive_damping: float = 0.0
    gain: float = 1.0
    angular_weight: float | None = None  # m/rad; None: 1.0 with orientation, no rotation rows without
    coupling_update: str = "reduced"
    axis_tolerance: tuple[float, ...] | None = None  # per-axis position bounds instead of the norm
    patience: int = 0  # stop an attempt after this many steps without a 0.1 % gain; 0 = never


@dataclass(frozen=True)
class _Layout:
    """What a chain's joints look like to the solver: computed once per chain."""

    var: np.ndarray  # indices of the solver's variables
    coupling_matrix: np.ndarray | None  # dq_full = C dx for the reduced coupling update
    lower: np.ndarray
    upper: np.ndarray
    revolute: np.ndarray
    bounds: tuple[list, list, list]  # lower, upper, revolute as lists for the scalar loop
    terms: tuple  # reduced update, per coupling: (joint, offset, lower, upper, ((variable, c), ...))
    arrays: tuple  # the chain for compiled.attempt_packed (compiled.pack_chain)
    packed_goals: dict  # goal templates of compiled.pack_goal by rows (Refiner._packed_goal)


_LAYOUTS: weakref.WeakKeyDictionary[Chain, dict] = weakref.WeakKeyDictionary()


def _layout(chain: Chain, project: bool) -> _Layout:
    cached = _LAYOUTS.setdefault(chain, {})
    if project not in cached:
        var = np.arange(chain.n) if (project or not chain.couplings) else chain.free.copy()
        matrix = None
        if chain.couplings and not project:
            matrix = np.zeros((chain.n, var.size))
            matrix[var, np.arange(var.size)] = 1.0
            for coupling in chain.couplings:
                matrix[coupling.joint] = coupling.coefficients[var]
        lower, upper, revolute = chain.lower[var], chain.upper[var], ~chain.prismatic[var]
        terms = (
            ()
            if matrix is None
            else tuple(
                (
                    c.joint,
                    c.offset,
                    float(chain.lower[c.joint]),
                    float(chain.upper[c.joint]),
                    tuple((j, float(c.coefficients[v])) for j, v in enumerate(var) if c.coefficients[v] != 0.0),
                )
                for c in chain.couplings
            )
        )
        fixed, motion = compiled.chain_arrays(chain)
        joints = [c.joint for c in chain.couplings]  # project: var is every joint (compiled.attempt tells so)
        arrays = compiled.pack_chain(
            fixed,
            motion,
            var.astype(np.int64),
            np.eye(chain.n) if matrix is None else matrix,
            np.array(joints, dtype=np.int64),
            np.array([c.offset for c in chain.couplings], dtype=float),
            np.array([c.coefficients for c in chain.couplings], dtype=float).reshape(len(joints), chain.n),
            chain.lower[joints].astype(float),
            chain.upper[joints].astype(float),
            lower.astype(float),
            upper.astype(float),
            revolute.astype(np.bool_),
        )
        cached[project] = _Layout(
            var, matrix, lower, upper, revolute, (lower.tolist(), upper.tolist(), revolute.tolist()), terms, arrays, {}
        )
    return cached[project]


def measured_attempt(
    chain: Chain, goal: Goal, request: Request, step: StepSettings, q0: np.ndarray, max_steps: int
) -> tuple[Attempt, np.ndarray] | None:
    """The first attempt of a solve and the measures of its end in one compiled call
    (``compiled.attempt_measured``: same steps as ``Refiner.run``), or None where the compiled
    attempt does not apply.  Why: at 2-4 joints the Python around one compiled attempt (building
    a Refiner, then FK and errors again for the result) cost more than the attempt itself."""
    if not (
        compiled.AVAILABLE
        and goal.task is None
        and step.axis_tolerance is None
        and not request.record_history
        and max_steps <= compiled.MAX_COMPILED_STEPS
    ):
        return None
    layout = _layout(chain, step.coupling_update == "project")
    has_rotation = goal.rotation is not None
    weight = step.angular_weight
    if weight is None:
        weight = 1.0 if has_rotation else 0.0
    key = (has_rotation, weight, step.damping, step.adaptive_damping, step.gain)
    plan = layout.packed_goals.get(key)
    if plan is None:
        position_rows = [0, 1] if chain.planar else [0, 1, 2]
        rotation_rows = ([5] if chain.planar else [3, 4, 5]) if has_rotation or weight > 0.0 else []
        floats, ints = compiled.pack_goal(
            np.array(position_rows + rotation_rows, dtype=np.int64),
            np.array([1.0] * len(position_rows) + [weight] * len(rotation_rows)),
            np.zeros(3),
            _EYE3,
            has_rotation,
            chain.planar,
        )
        # the step settings follow the goal (compiled.attempt_measured): one array less to pass
        plan = (
            np.concatenate([floats, [step.damping**2, step.adaptive_damping, step.gain, 0.0, 0.0]]),
            ints,
            chain.n + 18 + (2 if chain.planar else 3) + ((1 if chain.planar else 3) if has_rotation else 0),
        )
        if len(layout.packed_goals) < 64:
            layout.packed_goals[key] = plan
    template, ints, size = plan
    out = np.empty(size)
    chain_floats, chain_ints = layout.arrays
    converged, iterations, score = compiled.attempt_measured(
        chain_floats,
        chain_ints,
        template,
        ints,
        goal.position,
        goal.rotation if has_rotation else _EYE3,
        request.tolerance**2,
        request.orientation_tolerance,
        q0,
        max_steps,
        step.patience,
        out,
    )
    n = chain.n
    return Attempt(out[:n], converged, iterations, score), out


def measured_result(
    chain: Chain, out: np.ndarray, attempt: Attempt, *, solver: str, message: str, attempts: int = 1
) -> IKResult:
    """The IKResult of ``measured_attempt``'s output (what ``base.finish`` computes, already done)."""
    n = chain.n
    return IKResult(
        q=out[:n],
        success=attempt.converged,
        position_error=float(out[n + 16]),
        orientation_error=float(out[n + 17]),
        iterations=attempt.iterations,
        message=message,
        reached=out[n : n + 16].reshape(4, 4),
        error=out[n + 18 :],
        solver=solver,
        attempts=attempts,
    )


@dataclass
class Attempt:
    """Outcome of refining from one start."""

    q: np.ndarray  # best joint vector of the attempt (full, within limits)
    converged: bool
    iterations: int
    score: float  # weighted squared task error at q
    timed_out: bool = False


class Refiner:
    """Iterates the DLS step for one goal; construct once per solve, ``run`` per start."""

    def __init__(self, chain: Chain, goal: Goal, request: Request, step: StepSettings) -> None:
        self.chain = chain
        self.request = request
        self.step = step
        self.history: list[IterationRecord] | None = [] if request.record_history else None
        self.target = goal.position.tolist()
        self.task = goal.task
        self.goal = goal
        self.rotation = None if goal.rotation is None else goal.rotation.ravel().tolist()
        weight = step.angular_weight
        if weight is None:
            weight = 1.0 if self.rotation is not None else 0.0
        self.angular_weight = weight
        self.use_rotation_rows = self.rotation is not None or weight > 0.0 or self.task is not None
        self.position_rows = [0, 1] if chain.planar else [0, 1, 2]
        self.rotation_rows = ([5] if chain.planar else [3, 4, 5]) if self.use_rotation_rows else []
        self.m = len(self.position_rows) + len(self.rotation_rows)
        self.tolerance2 = request.tolerance**2
        self.orientation_tolerance = request.orientation_tolerance
        self.axis_tolerance = step.axis_tolerance
        layout = _layout(chain, step.coupling_update == "project")
        self.var, self.coupling_matrix = layout.var, layout.coupling_matrix
        self.lower, self.upper, self.revolute = layout.lower, layout.upper, layout.revolute
        self.bounds = layout.bounds
        self.terms = layout.terms
        self.lam2 = step.damping**2
        reduced = not chain.couplings or step.coupling_update == "reduced"
        self.arrays = layout.arrays
        # the compiled attempt (compiled.py) covers what the scalar and pose loops do, weighted rows and both
        # coupling updates
        self.compiled = (
            compiled.AVAILABLE and self.task is None and self.axis_tolerance is None and self.history is None
        )
        if self.compiled:
            self.compiled_goal = self._packed_goal(layout, goal)
            self.compiled_settings = np.array(
                (self.lam2, step.adaptive_damping, step.gain, self.tolerance2, self.orientation_tolerance)
            )
        self.fast = None
        if self.task is not None:
            pass  # partial poses take the generic loop
        elif self.axis_tolerance is None and reduced and not self.use_rotation_rows:
            self.fast = self._run_scalar
        elif self.axis_tolerance is None and not chain.couplings and not chain.planar and self.rotation is not None:
            self.fast = self._run_pose

    # --- helpers -----------------------------------------------------------------------
    def _packed_goal(self, layout: _Layout, goal: Goal) -> tuple[np.ndarray, np.ndarray]:
        """``compiled.pack_goal`` of this goal; the part that depends on the rows only is made
        once per chain and row set (this runs at every solve)."""
        key = (goal.rotation is not None, self.use_rotation_rows, self.angular_weight)
        template = layout.packed_goals.get(key)
        if template is None:
            rows = self.position_rows + self.rotation_rows
            template = compiled.pack_goal(
                np.array(rows, dtype=np.int64),
                np.array([1.0] * len(self.position_rows) + [self.angular_weight] * len(self.rotation_rows)),
                np.zeros(3),
                _EYE3,
                goal.rotation is not None,
                self.chain.planar,
            )
            if len(layout.packed_goals) < 64:
                layout.packed_goals[key] = template
        floats = template[0].copy()
        floats[:3] = goal.position
        if goal.rotation is not None:
            floats[3:12] = goal.rotation.ravel()
        return floats, template[1]

    def expand(self, x: np.ndarray) -> np.ndarray:
        """Full joint vector from the variables (coupled joints derived, clamped)."""
        if self.var.size == self.chain.n and not self.chain.couplings:
            return x
        q = np.zeros(self.chain.n)
        q[self.var] = x
        return self.chain.apply_coupling(q)

    def keep_in_limits(
        self, x: np.ndarray, values: list, jac: np.ndarray, error: np.ndarray, damping: float
    ) -> np.ndarray | None:
        """The stepped variables ``values`` (a list, modified) brought into the limits:
        2 pi wraps first, then saturated variables on their limit and the others
        solved again for the error left.  None if the step is not finite."""
        if not math.isfinite(sum(values)):
            return None
        lower, upper, revolute = self.bounds
        fixed = _wrap_or_saturate(values, lower, upper, revolute)
        if fixed:
            start = x.tolist()
            keep = np.array([0.0 if i in fixed else 1.0 for i in range(len(start))])
            move = np.array([fixed[i] - start[i] if i in fixed else 0.0 for i in range(len(start))])
            rest = error - jac @ move
            jac = jac * keep  # saturated columns removed
            a = jac @ jac.T
            a.flat[:: a.shape[0] + 1] += damping
            values = (x + self.step.gain * (_solve(a, rest) @ jac)).tolist()
            if not math.isfinite(sum(values)):
                return None
            for i, limit in fixed.items():
                values[i] = limit
            for i, limit in _wrap_or_saturate(values, lower, upper, revolute).items():
                values[i] = limit
        return np.array(values)

    def closest(self, candidates: np.ndarray) -> np.ndarray:
        """The candidate (a row) with the least weighted task error."""
        if len(candidates) == 1:
            return candidates[0]
        if self.compiled:
            return candidates[compiled.best_start(*self.arrays, *self.compiled_goal, candidates)]
        return min(candidates, key=self.score)

    def score(self, q: np.ndarray) -> float:
        """Weighted squared task error at q (what the steps reduce)."""
        out = self.chain.kernel.pose(q.tolist())
        if self.task is not None:
            error = task_rows(
                self.task,
                self.goal.position,
                self.goal.rotation,
                np.array(out[:3]),
                np.array(out[3:12]).reshape(3, 3),
                None,
            )[0]
            return float(error @ error)
        tx, ty, tz = self.target
        ex, ey, ez = tx - out[0], ty - out[1], tz - out[2]
        score = ex * ex + ey * ey + (0.0 if self.chain.planar else ez * ez)
        if self.rotation is not None:
            wx, wy, wz = rotation_error(*out[3:12], *self.rotation)
            w2 = wz * wz if self.chain.planar else wx * wx + wy * wy + wz * wz
            score += self.angular_weight**2 * w2
        return score

    def _record(self, iteration: int, q, position_error2: float, orientation_error: float, attempt: int) -> None:
        self.history.append(
            IterationRecord(iteration, np.array(q, dtype=float), math.sqrt(position_error2), orientation_error, attempt)
        )

    # --- the loop ------------------------------------------------------------------------
    def run(self, q0: np.ndarray, max_steps: int, attempt: int = 0) -> Attempt:
        """Refine from q0 (full vector, within limits) for at most ``max_steps`` steps."""
        if self.compiled and max_steps <= compiled.MAX_COMPILED_STEPS:
            return self._run_compiled(q0, max_steps)
        return (self.fast or self._run_numpy)(q0, max_steps, attempt)

    def _run_compiled(self, q0: np.ndarray, max_steps: int) -> Attempt:
        """``compiled.attempt``: the steps of ``_run_numpy``, compiled (no deadline inside: short runs only)."""
        q, converged, iterations, score = compiled.attempt_packed(
            *self.arrays,
            *self.compiled_goal,
            self.compiled_settings,
            np.require(q0, dtype=float, requirements="CW"),  # one compiled variant: read-only arrays type apart
            max_steps,
            self.step.patience,
        )
        return Attempt(q, converged, iterations, score)

    def _run_numpy(self, q0: np.ndarray, max_steps: int, attempt: int) -> Attempt:
        chain, step = self.chain, self.step
        kernel = chain.kernel.pose_jacobian if self.use_rotation_rows else chain.kernel.position_jacobian
        n = chain.n
        rows = self.position_rows + self.rotation_rows
        weights = np.array([1.0] * len(self.position_rows) + [self.angular_weight] * len(self.rotation_rows))
        tx, ty, tz = self.target
        d = self.rotation
        rotation_target = d is not None
        axis = self.axis_tolerance
        planar = chain.planar
        lam2, adaptive, gain = self.lam2, step.adaptive_damping, step.gain
        coupling = self.coupling_matrix
        project = step.coupling_update == "project" and chain.couplings
        deadline = self.request.deadline
        history = self.history
        x = q0[self.var].astype(float)
        q = q0.astype(float)
        best_q, best_score = q, math.inf
        patience, stale = step.patience, 0
        for iteration in range(max_steps + 1):
            out = kernel(q.tolist())
            ex, ey, ez = tx - out[0], ty - out[1], tz - out[2]
            pos2 = ex * ex + ey * ey + (0.0 if planar else ez * ez)
            if self.use_rotation_rows:
                wx, wy, wz = rotation_error(*out[3:12], *d) if rotation_target else (0.0, 0.0, 0.0)
                jacobian = np.array(out[12])
            else:
                wx = wy = wz = 0.0
                jacobian = np.array(out[3:])
            ori = (abs(wz) if planar else math.sqrt(wx * wx + wy * wy + wz * wz)) if rotation_target else 0.0
            if axis is None:
                position_ok = pos2 <= self.tolerance2
            else:
                position_ok = abs(ex) <= axis[0] and abs(ey) <= axis[1] and (planar or abs(ez) <= axis[2])
            if self.task is not None:  # partial pose: the task's rows (solvers/task.py)
                error, task_jacobian, position_error, ori = task_rows(
                    self.task,
                    self.goal.position,
                    self.goal.rotation,
                    np.array(out[:3]),
                    np.array(out[3:12]).reshape(3, 3),
                    jacobian.reshape(6, n),
                )
                pos2 = position_error * position_error
                position_ok = pos2 <= self.tolerance2
            else:
                error = np.array((ex, ey, ez, wx, wy, wz))[rows] * weights
            if history is not None:
                self._record(iteration, q, pos2, ori, attempt)
            score = float(error @ error)
            if position_ok and ori <= self.orientation_tolerance:
                return Attempt(q, True, iteration, score)
            if score < best_score:
                stale = stale + 1 if score > 0.999 * best_score else 0
                best_q, best_score = q, score
            else:
                stale += 1
            if iteration == max_steps or (patience and stale >= patience):
                break
            if time.perf_counter() > deadline:
                return Attempt(best_q, False, iteration, best_score, timed_out=True)
            jac = task_jacobian if self.task is not None else jacobian.reshape(-1, n)[rows] * weights[:, None]
            if coupling is not None:
                jac = jac @ coupling
            damping = lam2 + adaptive * score
            a = jac @ jac.T
            a.flat[:: a.shape[0] + 1] += damping
            x = self.keep_in_limits(x, (x + gain * (_solve(a, error) @ jac)).tolist(), jac, error, damping)
            if x is None:  # a singular system: give up this attempt
                break
            if project:
                q = chain.apply_coupling(x)
                x = q.copy()
            else:
                q = self.expand(x)
        return Attempt(best_q, False, iteration, best_score)

    def _run_pose(self, q0: np.ndarray, max_steps: int, attempt: int) -> Attempt:
        """Same step as ``_run_numpy`` for a spatial full-pose goal without coupling:
        errors on floats, numpy only for the 6 x 6 solve."""
        n = self.chain.n
        kernel = self.chain.kernel.pose_jacobian
        tx, ty, tz = self.target
        d00, d01, d02, d10, d11, d12, d20, d21, d22 = self.rotation
        weight = self.angular_weight
        lam2, adaptive, gain = self.lam2, self.step.adaptive_damping, self.step.gain
        tolerance2 = self.tolerance2
        orientation_tolerance2 = self.orientation_tolerance**2
        lower_list, upper_list, _ = self.bounds
        eye = np.eye(6)
        deadline = self.request.deadline
        history = self.history
        q = q0.astype(float)
        best_q, best_score = q, math.inf
        patience, stale = self.step.patience, 0
        for iteration in range(max_steps + 1):
            x, y, z, r00, r01, r02, r10, r11, r12, r20, r21, r22, flat = kernel(q.tolist())
            ex, ey, ez = tx - x, ty - y, tz - z
            wx, wy, wz = rotation_error(
                r00, r01, r02, r10, r11, r12, r20, r21, r22, d00, d01, d02, d10, d11, d12, d20, d21, d22
            )
            pos2 = ex * ex + ey * ey + ez * ez
            ori2 = wx * wx + wy * wy + wz * wz
            if history is not None:
                self._record(iteration, q, pos2, math.sqrt(ori2), attempt)
            if pos2 <= tolerance2 and ori2 <= orientation_tolerance2:
                return Attempt(q, True, iteration, pos2 + weight * weight * ori2)
            score = pos2 + weight * weight * ori2
            if score < best_score:
                stale = stale + 1 if score > 0.999 * best_score else 0
                best_q, best_score = q, score
            else:
                stale += 1
            if iteration == max_steps or (patience and stale >= patience):
                break
            if time.perf_counter() > deadline:
                return Attempt(best_q, False, iteration, best_score, timed_out=True)
            jac = np.array(flat).reshape(6, n)
            if weight != 1.0:
                jac[3:] *= weight
            error = np.array((ex, ey, ez, wx * weight, wy * weight, wz * weight))
            damping = lam2 + adaptive * score
            step = _solve(jac @ jac.T + damping * eye, error) @ jac
            x_new = q + step if gain == 1.0 else q + gain * step
            values = x_new.tolist()
            if not (all(map(le, lower_list, values)) and all(map(le, values, upper_list))):
                x_new = self.keep_in_limits(q, values, jac, error, damping)
                if x_new is None:  # a singular system: give up this attempt
                    break
            q = x_new
        return Attempt(best_q, False, iteration, best_score)

    def _run_scalar(self, q0: np.ndarray, max_steps: int, attempt: int) -> Attempt:
        """Same step as ``_run_numpy`` for a position-only goal, on floats: 3 rows
        (planar chains have a zero z row and ez = 0, which leaves the x, y solve
        unchanged), reduced couplings as the chain-rule columns."""
        kernel = self.chain.kernel.position_jacobian
        planar = self.chain.planar
        tx, ty, tz = self.target
        lam2, adaptive, gain = self.lam2, self.step.adaptive_damping, self.step.gain
        tolerance2 = self.tolerance2
        lower, upper, revolute = self.bounds
        var, terms = self.var.tolist(), self.terms
        deadline = self.request.deadline
        history = self.history
        q = q0.tolist()
        x_list = [q[v] for v in var] if terms else q
        best_q, best_score = q, math.inf
        patience, stale = self.step.patience, 0
        for iteration in range(max_steps + 1):
            x, y, z, jx, jy, jz = kernel(q)
            ex, ey, ez = tx - x, ty - y, (0.0 if planar else tz - z)
            score = ex * ex + ey * ey + ez * ez
            if history is not None:
                self._record(iteration, q, score, 0.0, attempt)
            if score <= tolerance2:
                return Attempt(np.array(q), True, iteration, score)
            if score < best_score:
                stale = stale + 1 if score > 0.999 * best_score else 0
                best_q, best_score = q, score
            else:
                stale += 1
            if iteration == max_steps or (patience and stale >= patience):
                break
            if time.perf_counter() > deadline:
                return Attempt(np.array(best_q), False, iteration, best_score, timed_out=True)
            if terms:  # J_r = J_free + J_k c: the coupled joints follow the free ones
                fx, fy, fz = jx, jy, jz
                jx, jy, jz = [fx[v] for v in var], [fy[v] for v in var], [fz[v] for v in var]
                for joint, _, _, _, pairs in terms:
                    gx, gy, gz = fx[joint], fy[joint], fz[joint]
                    for j, c in pairs:
                        jx[j] += c * gx
                        jy[j] += c * gy
                        jz[j] += c * gz
            damping = lam2 + adaptive * score
            new = _scalar_step(x_list, jx, jy, jz, ex, ey, ez, damping, gain)
            if not math.isfinite(sum(new)):  # a singular system: give up this attempt
                break
            fixed = _wrap_or_saturate(new, lower, upper, revolute)
            if fixed:  # saturated joints on their limit, the others solve for the rest
                jx, jy, jz = list(jx), list(jy), list(jz)
                for i, limit in fixed.items():
                    move = limit - x_list[i]
                    ex, ey, ez = ex - jx[i] * move, ey - jy[i] * move, ez - jz[i] * move
                    jx[i] = jy[i] = jz[i] = 0.0
                new = _scalar_step(x_list, jx, jy, jz, ex, ey, ez, damping, gain)
                if not math.isfinite(sum(new)):
                    break
                for i, limit in fixed.items():
                    new[i] = limit
                for i, limit in _wrap_or_saturate(new, lower, upper, revolute).items():
                    new[i] = limit
            x_list = new
            if terms:
                q = list(q)
                for j, v in enumerate(var):
                    q[v] = new[j]
                for joint, offset, low, high, pairs in terms:
                    q[joint] = min(max(offset + sum(c * new[j] for j, c in pairs), low), high)
            else:
                q = new
        return Attempt(np.array(best_q), False, iteration, best_score)


def _wrap_or_saturate(values: list, lower: list, upper: list, revolute: list) -> dict:
    """Wrap out-of-range revolute values by 2 pi when that lands in range (in place);
    return {index: limit} for the values that stay outside."""
    fixed = {}
    for i, value in enumerate(values):
        if value > upper[i] or value < lower[i]:
            turn = -TWO_PI if value > upper[i] else TWO_PI
            if revolute[i] and lower[i] <= value + turn <= upper[i]:
                values[i] = value + turn
            else:
                fixed[i] = upper[i] if value > upper[i] else lower[i]
    return fixed


def _scalar_step(q, jx, jy, jz, ex, ey, ez, damping, gain):
    """q + gain J^T (J J^T + damping I)^-1 e for a 3 x n J, by cofactors."""
    a00 = sum(map(mul, jx, jx)) + damping
    a01 = sum(map(mul, jx, jy))
    a02 = sum(map(mul, jx, jz))
    a11 = sum(map(mul, jy, jy)) + damping
    a12 = sum(map(mul, jy, jz))
    a22 = sum(map(mul, jz, jz)) + damping
    c00, c01, c02 = a11 * a22 - a12 * a12, a02 * a12 - a01 * a22, a01 * a12 - a02 * a11
    c11, c12, c22 = a00 * a22 - a02 * a02, a01 * a02 - a00 * a12, a00 * a11 - a01 * a01
    k = gain / (a00 * c00 + a01 * c01 + a02 * c02)
    y0 = (c00 * ex + c01 * ey + c02 * ez) * k
    y1 = (c01 * ex + c11 * ey + c12 * ez) * k
    y2 = (c02 * ex + c12 * ey + c22 * ez) * k
    return [qi + y0 * gx + y1 * gy + y2 * gz for qi, gx, gy, gz in zip(q, jx, jy, jz, strict=True)]
