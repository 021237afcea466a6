"""The one interface every IK solver implements, its result and request checks.

``Solver.solve(chain, target, *, seed, with_orientation, tolerance, ...)``
validates everything first (``InvalidRequestError`` / ``SolverNotApplicableError``),
then runs the solver's algorithm under a wall-clock deadline.

Targets: a position (x, y, z), or (x, y) for planar chains, or a 4x4 pose.
For planar chains only x, y count (and yaw when orientation is asked for).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..chain import Chain
from ..errors import InvalidRequestError, SolverNotApplicableError
from ..transforms import rotation_error
from . import compiled
from .task import Task, task_rows

DEFAULT_TOLERANCE = 1e-5  # m for position, rad for orientation
DEFAULT_MAX_ITERATIONS = 1000
DEFAULT_TIMEOUT = 0.005  # s; TRAC-IK's customary budget
MAX_ITERATIONS_LIMIT = 1_000_000  # requests beyond these are refused as absurd
MAX_TIMEOUT = 60.0
MAX_TARGET_DISTANCE = 1e6  # m from the base frame's origin; squared errors would overflow near 1e154
# m; solvers compare squared errors with tolerance ** 2, which overflows above ~1.3e154.  Targets lie
# within MAX_TARGET_DISTANCE, so a larger tolerance could only mean "anything goes".
MAX_TOLERANCE = MAX_TARGET_DISTANCE


@dataclass
class IterationRecord:
    """One iteration of a solve, for plots: joint vector and errors *before* the step."""

    iteration: int
    q: np.ndarray
    position_error: float
    orientation_error: float
    attempt: int = 0


@dataclass
class IKResult:
    """What a solve found; ``q`` is always within limits, even on failure.

    ``position_error`` is |target - reached| in metres (x, y only for planar
    chains); ``orientation_error`` the rotation angle left in radians, 0.0 when
    orientation was not requested.  ``error`` is the task-space error vector
    (position rows then rotation-vector rows).  ``iterations`` counts steps
    taken over all attempts (restarts / candidates).
    """

    q: np.ndarray
    success: bool
    position_error: float
    orientation_error: float
    iterations: int
    message: str
    reached: np.ndarray
    error: np.ndarray
    solver: str
    attempts: int = 1
    elapsed: float = 0.0
    history: list[IterationRecord] | None = None


class Goal(NamedTuple):
    """A checked target: position (3,), rotation (3, 3) or None, and the partial-pose
    task (``task.Task``) or None for position only / full pose.  (Immutable; a named tuple
    rather than a frozen dataclass: it is built at every solve, in 0.3 us instead of 0.5.)"""

    position: np.ndarray
    rotation: np.ndarray | None
    task: Task | None = None


@dataclass
class Request:
    """Checked common settings of one solve."""

    with_orientation: bool
    tolerance: float
    orientation_tolerance: float
    max_iterations: int
    deadline: float
    record_history: bool
    started: float = field(default_factory=time.perf_counter)


_FLOAT = np.dtype(float)
_NO_ROTATION = np.empty((3, 3))  # compiled.pose_goal's output when it writes none (position-only goals)


def parse_goal(chain: Chain, target, with_orientation: bool, task: Task | None = None) -> Goal:
    """Goal from a 2/3-vector or a 4x4 pose; InvalidRequestError if malformed."""
    if task is not None:
        return _task_goal(chain, target, task)
    if compiled.AVAILABLE and type(target) is np.ndarray and target.dtype is _FLOAT and target.shape == (4, 4):
        # the common case in one compiled call: the same checks and the same goal as below
        position = np.empty(3)
        rotation = np.empty((3, 3)) if with_orientation else None
        problem = compiled.pose_goal(
            target,
            MAX_TARGET_DISTANCE,
            (2 if chain.planar else 1) if with_orientation else 0,
            position,
            _NO_ROTATION if rotation is None else rotation,
        )
        if problem != compiled.POSE_OK:
            _refuse(target[:3, 3].tolist() if problem == compiled.POSE_ABSURD else [], problem)
        return Goal(position, rotation)
    try:
        array = np.array(target, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidRequestError(f"target must be numbers, got {target!r}") from exc
    if array.shape == (4, 4):
        problem = compiled.check_pose(array, MAX_TARGET_DISTANCE)
        if problem != compiled.POSE_OK:
            _refuse(array[:3, 3].tolist() if problem == compiled.POSE_ABSURD else [], problem)
        if not with_orientation:
            return Goal(array[:3, 3].copy(), None)
        if chain.planar:  # only the yaw of the target counts in the plane
            yaw = math.atan2(array[1, 0], array[0, 0])
            c, s = math.cos(yaw), math.sin(yaw)
            return Goal(array[:3, 3].copy(), np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]))
        return Goal(array[:3, 3].copy(), array[:3, :3].copy())
    values = array.ravel().tolist()  # checks on floats: numpy's per-call overhead dominates on 3 values
    if not all(map(math.isfinite, values)):
        _refuse(values, compiled.POSE_NOT_FINITE)
    if values and max(map(abs, values)) > MAX_TARGET_DISTANCE:
        _refuse(values, compiled.POSE_ABSURD)
    if with_orientation:
        raise InvalidRequestError("orientation requested but the target is a position: pass a 4x4 pose")
    if array.shape == (3,):
        return Goal(array, None)
    if array.shape == (2,) and chain.planar:
        return Goal(np.array([array[0], array[1], 0.0]), None)
    raise InvalidRequestError(
        f"target must be a position (x, y, z), a planar (x, y) or a 4x4 pose, got shape {array.shape}"
    )


def _refuse(position: list, problem: int) -> None:
    """InvalidRequestError for a target that ``compiled.check_pose`` (or the same checks on a
    position) found wrong."""
    if problem == compiled.POSE_NOT_FINITE:
        raise InvalidRequestError("target must be finite (no NaN or inf)")
    if problem == compiled.POSE_ABSURD:
        raise InvalidRequestError(
            f"target position {position} is absurd: coordinates beyond {MAX_TARGET_DISTANCE:g} m are refused"
        )
    raise InvalidRequestError("target pose is not a rigid transform (rotation not orthonormal)")


def _task_goal(chain: Chain, target, task: Task) -> Goal:
    """Goal of a partial-pose task: a position, or a 4x4 pose when rotation rows need one."""
    if chain.planar:
        raise InvalidRequestError(
            "partial-pose tasks are for spatial chains (a planar chain takes x, y and yaw with with_orientation)"
        )
    pose = np.asarray(target, dtype=float) if np.shape(target) == (4, 4) else None
    goal = parse_goal(chain, target, pose is not None)
    if task.uses_rotation_target and goal.rotation is None:
        raise InvalidRequestError("task weights on rotation need a target orientation: pass a 4x4 pose")
    return Goal(goal.position, goal.rotation, task)


def _seed(chain: Chain, seed) -> np.ndarray:
    """``chain.checked_clamp(seed, "seed")``: a float vector of the chain's length, as one compiled
    call (``compiled.clamp_finite``; the Python checks and clamp cost ~1.5 us at 3 joints); other
    seeds, and non-finite ones for the message, go through the chain's checks."""
    if compiled.AVAILABLE and type(seed) is np.ndarray and seed.dtype is _FLOAT and seed.shape == chain.lower.shape:
        q0 = np.empty(seed.shape)
        # writable: numba types a read-only array (a frozen config's home) apart, and compiles a second variant
        if compiled.clamp_finite(np.require(seed, requirements="W"), chain.lower, chain.upper, q0):
            return q0
    return chain.checked_clamp(seed, "seed")


def _iterations(value) -> int:
    if type(value) is int and 1 <= value <= MAX_ITERATIONS_LIMIT:  # the common case, in one test
        return value
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= MAX_ITERATIONS_LIMIT:
        raise InvalidRequestError(f"max_iterations must be an integer in [1, {MAX_ITERATIONS_LIMIT}], got {value!r}")
    return int(value)


def _positive(name: str, value, limit: float) -> float:
    if type(value) is float and 0.0 < value <= limit:  # the common case, in one test (NaN fails it)
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise InvalidRequestError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not (math.isfinite(value) and 0.0 < value <= limit):
        raise InvalidRequestError(f"{name} must be a finite number in (0, {limit:g}], got {value}")
    return value


class Solver:
    """Base class: checks and common plumbing; subclasses implement ``_solve``.

    ``options`` maps each solver-specific option to its default; unknown options
    are refused, so a typo cannot silently fall back to a default.
    """

    name = ""
    options: dict = {}
    # whether this solver's solves (most of them) run compiled code anyway: only then is the seed
    # checked compiled (``_seed``), so that solvers without compiled code (ccd, analytic) do not pay
    # numba's first call in a process (~0.3 s here) inside their deadline
    runs_compiled = False

    def check(self, chain: Chain, with_orientation: bool = False) -> None:
        """Raise SolverNotApplicableError if this solver cannot serve the request."""
        if with_orientation and not chain.can_orient:
            need = "3 independent joints (x, y, yaw)" if chain.planar else "6 independent joints"
            raise SolverNotApplicableError(
                f"chain '{chain.name}' cannot reach a full orientation: it has {chain.free.size} "
                f"independent joints and a {'planar' if chain.planar else 'spatial'} pose needs {need}"
            )

    def check_task(self, chain: Chain) -> None:
        """Raise SolverNotApplicableError if this solver cannot drive a partial-pose task."""
        raise SolverNotApplicableError(f"solver '{self.name}' takes no partial-pose task (dls and pinv do)")

    def solve(
        self,
        chain: Chain,
        target,
        *,
        seed=None,
        with_orientation: bool = False,
        tolerance: float = DEFAULT_TOLERANCE,
        orientation_tolerance: float | None = None,
        max_iterations: int = DEFAULT_MAX_ITERATIONS,
        timeout: float = DEFAULT_TIMEOUT,
        record_history: bool = False,
        task: Task | None = None,
        **options,
    ) -> IKResult:
        """Solve IK for ``target``; see the module docstring for the forms of target.

        ``task`` (``task.parse_task``) asks for a partial pose instead: weighted axes
        and/or a tool axis pointing along a direction; ``with_orientation`` is then unused.

        ``seed`` (default: zeros clamped into the limits) is clamped into the limits
        and its coupled joints derived.  ``tolerance`` is metres for position and,
        unless ``orientation_tolerance`` is given, radians for orientation.
        """
        started = time.perf_counter()
        if task is not None:
            with_orientation = False
            self.check_task(chain)
        self.check(chain, bool(with_orientation))
        settings = self._configured(options, chain.planar)
        goal = parse_goal(chain, target, bool(with_orientation), task)
        tolerance = _positive("tolerance", tolerance, MAX_TOLERANCE)
        orientation_tolerance = (
            tolerance
            if orientation_tolerance is None
            else _positive("orientation_tolerance", orientation_tolerance, math.pi)
        )
        max_iterations = _iterations(max_iterations)
        timeout = _positive("timeout", timeout, MAX_TIMEOUT)
        q0 = (
            chain.clamp(np.zeros(chain.n))
            if seed is None
            else (_seed(chain, seed) if self.runs_compiled else chain.checked_clamp(seed, "seed"))
        )
        if chain.couplings:
            q0 = chain.apply_coupling(q0)
        request = Request(
            bool(with_orientation),
            tolerance,
            orientation_tolerance,
            max_iterations,
            started + timeout,
            bool(record_history),
            started,
        )
        result = self._solve(chain, goal, q0, request, settings)
        result.elapsed = time.perf_counter() - started
        return result

    def _configured(self, options: dict, planar: bool):
        """``configure`` of the defaults updated with ``options``, memoised: the same
        options are checked once, not at every solve."""
        cache = self.__dict__.setdefault("_configurations", {})
        if not options and planar in cache:  # the common case, without building a key
            return cache[planar]
        try:
            key = (planar, tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in options.items())))
            hash(key)
        except TypeError:
            key = None
        if key is not None and key in cache:
            return cache[key]
        unknown = set(options) - set(self.options)
        if unknown:
            raise InvalidRequestError(
                f"solver '{self.name}' has no option(s) {sorted(unknown)}; it takes {sorted(self.options)}"
            )
        configuration = self.configure({**self.options, **options}, planar)
        if key is not None and len(cache) < 256:
            cache[key] = configuration
            if not options:
                cache[planar] = configuration
        return configuration

    def configure(self, settings: dict, planar: bool):
        """Checked form of the solver options (InvalidRequestError if bad)."""
        return settings

    def _solve(self, chain: Chain, goal: Goal, q0: np.ndarray, request: Request, configuration) -> IKResult:
        raise NotImplementedError


def finish(
    chain: Chain,
    goal: Goal,
    q: np.ndarray,
    request: Request,
    *,
    solver: str,
    iterations: int,
    message: str,
    attempts: int = 1,
    history=None,
    converged: bool | None = None,
) -> IKResult:
    """Build the result at q: reached pose, errors, and success against the tolerances."""
    q = np.asarray(q, dtype=float)
    reached = chain_pose(chain, q)
    position_error, orientation_error, error = measure(chain, goal, reached)
    if converged is None:
        converged = position_error <= request.tolerance and orientation_error <= request.orientation_tolerance
    return IKResult(
        q=q,
        success=bool(converged),
        position_error=position_error,
        orientation_error=orientation_error,
        iterations=iterations,
        message=message,
        reached=reached,
        error=error,
        solver=solver,
        attempts=attempts,
        history=history,
    )


def chain_pose(chain: Chain, q) -> np.ndarray:
    """4x4 tool pose from the fast kernel."""
    x, y, z, r00, r01, r02, r10, r11, r12, r20, r21, r22 = chain.kernel.pose(np.asarray(q, dtype=float).tolist())
    return np.array([[r00, r01, r02, x], [r10, r11, r12, y], [r20, r21, r22, z], [0.0, 0.0, 0.0, 1.0]])


def measure(chain: Chain, goal: Goal, reached: np.ndarray) -> tuple[float, float, np.ndarray]:
    """(position error, orientation error, error vector) of a reached pose."""
    if goal.task is not None:
        error, _, position_error, orientation_error = task_rows(
            goal.task, goal.position, goal.rotation, reached[:3, 3], reached[:3, :3], None
        )
        return position_error, orientation_error, error
    (r00, r01, r02, x), (r10, r11, r12, y), (r20, r21, r22, z), _ = reached.tolist()
    tx, ty, tz = goal.position.tolist()
    error = [tx - x, ty - y] if chain.planar else [tx - x, ty - y, tz - z]
    position_error = math.sqrt(sum(v * v for v in error))
    orientation_error = 0.0
    if goal.rotation is not None:
        w = rotation_error(r00, r01, r02, r10, r11, r12, r20, r21, r22, *goal.rotation.ravel().tolist())
        w = w[2:] if chain.planar else w
        orientation_error = math.sqrt(sum(v * v for v in w))
        error += w
    return position_error, orientation_error, np.array(error)
