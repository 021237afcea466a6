"""The DLS attempt of ``iterative.Refiner`` compiled with numba (optional).

Same equations as ``Refiner._run_numpy`` (see iterative.py), on arrays:

    FK/Jacobian  T = F_0 M_1(q_1) F_1 ... M_n(q_n) F_n   (Chain.segments; M = Rz, Tz or Tx)
    e   = weights * (p_target - p, rotation vector R -> R_target)[rows]
    l^2 = damping^2 + adaptive_damping |e|^2
    dx  = gain J_r^T (J_r J_r^T + l^2 I)^-1 e,   J_r = J[rows] C (C: reduced coupling)

('project' coupling update: every joint stepped with J[rows], then the coupled ones set from the others)

then the limits: 2 pi wraps, saturated variables on their limit and the others
solved again for the error left (one pass of Baerlocher & Boulic's clamping).

Why: in pure Python an iteration costs 5-10 us of interpreter overhead on 6-7
joints; compiled, well under 1 us.  numba has no wall clock, so an attempt runs
compiled only when it is short (``MAX_COMPILED_STEPS``: its worst case stays far
below a millisecond) and the restart loop, which watches the deadline, stays in
Python.  At 2-4 joints the Python around a compiled attempt cost more than the
attempt, so a solve's first attempt also measures its result in the same call
(``attempt_measured``), a float64 4x4 target is checked and made into the goal compiled
(``pose_goal``) and a float64 seed checked and clamped compiled (``clamp_finite``).
Compiling takes seconds once per machine: ``cache=True`` keeps the machine code in
__pycache__, and ``warm_up`` at a node's configure loads it.  Without numba (or with
AMR_IK_NO_NUMBA=1) everything runs in the Python loops.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..chain import MOTION_ROT_Z, MOTION_TRANS_X

MAX_COMPILED_STEPS = 64  # ~0.1 ms at most: the overrun past a deadline an attempt can cause
_MOTION_CODES = {MOTION_ROT_Z: 0, MOTION_TRANS_X: 2}  # anything else: Tz (1)

try:
    if os.environ.get("AMR_IK_NO_NUMBA"):
        raise ImportError("disabled by AMR_IK_NO_NUMBA")
    import numba
except ImportError:  # pragma: no cover - numba is a dependency; this keeps the library usable without it
    numba = None

AVAILABLE = numba is not None


def chain_arrays(chain) -> tuple[np.ndarray, np.ndarray]:
    """(fixed (n + 1, 4, 4), motion codes (n,)) of a chain, for the compiled loop."""
    fixed, motions = chain.segments()
    return (
        np.ascontiguousarray(np.array(fixed, dtype=float)),
        np.array([_MOTION_CODES.get(m, 1) for m in motions], dtype=np.int64),
    )


def _jit(function):
    return numba.njit(cache=True, fastmath=False, nogil=True)(function) if AVAILABLE else function


@_jit
def _pose_jacobian(fixed, motion, q, R, p, axes, points, jac):
    """Tool rotation into R (3, 3), position into p (3,), the geometric Jacobian into jac (6, n);
    axes and points (n, 3) are work space.  Scalars, not small arrays: no allocation per link."""
    n = motion.shape[0]
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    p0 = p1 = p2 = 0.0
    for i in range(n + 1):
        f = fixed[i]  # T <- T F: p' = R f_p + p, R' = R f_R
        p0, p1, p2 = (
            r00 * f[0, 3] + r01 * f[1, 3] + r02 * f[2, 3] + p0,
            r10 * f[0, 3] + r11 * f[1, 3] + r12 * f[2, 3] + p1,
            r20 * f[0, 3] + r21 * f[1, 3] + r22 * f[2, 3] + p2,
        )
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = (
            r00 * f[0, 0] + r01 * f[1, 0] + r02 * f[2, 0],
            r00 * f[0, 1] + r01 * f[1, 1] + r02 * f[2, 1],
            r00 * f[0, 2] + r01 * f[1, 2] + r02 * f[2, 2],
            r10 * f[0, 0] + r11 * f[1, 0] + r12 * f[2, 0],
            r10 * f[0, 1] + r11 * f[1, 1] + r12 * f[2, 1],
            r10 * f[0, 2] + r11 * f[1, 2] + r12 * f[2, 2],
            r20 * f[0, 0] + r21 * f[1, 0] + r22 * f[2, 0],
            r20 * f[0, 1] + r21 * f[1, 1] + r22 * f[2, 1],
            r20 * f[0, 2] + r21 * f[1, 2] + r22 * f[2, 2],
        )
        if i == n:
            break
        if motion[i] == 2:  # slides along x
            axes[i, 0], axes[i, 1], axes[i, 2] = r00, r10, r20
        else:
            axes[i, 0], axes[i, 1], axes[i, 2] = r02, r12, r22
        points[i, 0], points[i, 1], points[i, 2] = p0, p1, p2
        if motion[i] == 0:  # T <- T Rz(q): x' = c x + s y, y' = c y - s x
            c, s = math.cos(q[i]), math.sin(q[i])
            r00, r01 = c * r00 + s * r01, c * r01 - s * r00
            r10, r11 = c * r10 + s * r11, c * r11 - s * r10
            r20, r21 = c * r20 + s * r21, c * r21 - s * r20
        else:  # T <- T Tz(q) or T Tx(q)
            p0, p1, p2 = p0 + q[i] * axes[i, 0], p1 + q[i] * axes[i, 1], p2 + q[i] * axes[i, 2]
    R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2] = (
        r00,
        r01,
        r02,
        r10,
        r11,
        r12,
        r20,
        r21,
        r22,
    )
    p[0], p[1], p[2] = p0, p1, p2
    for i in range(n):
        a0, a1, a2 = axes[i, 0], axes[i, 1], axes[i, 2]
        if motion[i] == 0:
            d0, d1, d2 = p0 - points[i, 0], p1 - points[i, 1], p2 - points[i, 2]
            jac[0, i] = a1 * d2 - a2 * d1
            jac[1, i] = a2 * d0 - a0 * d2
            jac[2, i] = a0 * d1 - a1 * d0
            jac[3, i], jac[4, i], jac[5, i] = a0, a1, a2
        else:
            jac[0, i], jac[1, i], jac[2, i] = a0, a1, a2
            jac[3, i] = jac[4, i] = jac[5, i] = 0.0


@_jit
def _rotation_error(R, D):
    """World-frame rotation vector taking R to D (transforms.rotation_error).  E = D R^T in
    scalars, not an array: no allocation at every call."""
    e00 = D[0, 0] * R[0, 0] + D[0, 1] * R[0, 1] + D[0, 2] * R[0, 2]
    e01 = D[0, 0] * R[1, 0] + D[0, 1] * R[1, 1] + D[0, 2] * R[1, 2]
    e02 = D[0, 0] * R[2, 0] + D[0, 1] * R[2, 1] + D[0, 2] * R[2, 2]
    e10 = D[1, 0] * R[0, 0] + D[1, 1] * R[0, 1] + D[1, 2] * R[0, 2]
    e11 = D[1, 0] * R[1, 0] + D[1, 1] * R[1, 1] + D[1, 2] * R[1, 2]
    e12 = D[1, 0] * R[2, 0] + D[1, 1] * R[2, 1] + D[1, 2] * R[2, 2]
    e20 = D[2, 0] * R[0, 0] + D[2, 1] * R[0, 1] + D[2, 2] * R[0, 2]
    e21 = D[2, 0] * R[1, 0] + D[2, 1] * R[1, 1] + D[2, 2] * R[1, 2]
    e22 = D[2, 0] * R[2, 0] + D[2, 1] * R[2, 1] + D[2, 2] * R[2, 2]
    vx, vy, vz = 0.5 * (e21 - e12), 0.5 * (e02 - e20), 0.5 * (e10 - e01)
    sin_angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    cos_angle = 0.5 * (e00 + e11 + e22 - 1.0)
    if sin_angle > 1e-7:
        k = math.atan2(sin_angle, cos_angle) / sin_angle
        return vx * k, vy * k, vz * k
    if cos_angle > 0.0:
        return vx, vy, vz
    # angle ~ pi: axis from the symmetric part, E ~ 2 a a^T - I
    ax = math.sqrt(max(0.0, (e00 + 1.0) / 2.0))
    ay = math.sqrt(max(0.0, (e11 + 1.0) / 2.0))
    az = math.sqrt(max(0.0, (e22 + 1.0) / 2.0))
    if ax >= ay and ax >= az:
        ay, az = math.copysign(ay, e01 + e10), math.copysign(az, e02 + e20)
    elif ay >= az:
        ax, az = math.copysign(ax, e01 + e10), math.copysign(az, e12 + e21)
    else:
        ax, ay = math.copysign(ax, e02 + e20), math.copysign(ay, e12 + e21)
    return ax * math.pi, ay * math.pi, az * math.pi


@_jit
def _damped_step(jac, error, damping, gain, a, y, out):
    """out = gain J^T (J J^T + damping I)^-1 e, by Cholesky (the matrix is symmetric positive
    definite for damping > 0); a (m, m) and y (m,) are work space.  False on a singular system."""
    m, n = jac.shape
    for i in range(m):
        for j in range(i + 1):
            total = 0.0
            for k in range(n):
                total += jac[i, k] * jac[j, k]
            a[i, j] = total + (damping if i == j else 0.0)
    for j in range(m):  # A = L L^T, L in the lower triangle of a
        total = a[j, j]
        for k in range(j):
            total -= a[j, k] * a[j, k]
        if not total > 0.0:
            return False
        a[j, j] = math.sqrt(total)
        for i in range(j + 1, m):
            value = a[i, j]
            for k in range(j):
                value -= a[i, k] * a[j, k]
            a[i, j] = value / a[j, j]
    for i in range(m):  # L z = e
        value = error[i]
        for k in range(i):
            value -= a[i, k] * y[k]
        y[i] = value / a[i, i]
    for i in range(m - 1, -1, -1):  # L^T y = z
        value = y[i]
        for k in range(i + 1, m):
            value -= a[k, i] * y[k]
        y[i] = value / a[i, i]
    for k in range(n):
        total = 0.0
        for i in range(m):
            total += jac[i, k] * y[i]
        out[k] = gain * total
    return True


@_jit
def _wrap_or_saturate(values, lower, upper, revolute, saturated, limits):
    """Revolute values out of range moved by 2 pi when that lands in range (in place);
    the others marked saturated at their limit.  Returns how many are saturated."""
    count = 0
    two_pi = 2.0 * math.pi
    for i in range(values.shape[0]):
        v = values[i]
        if v > upper[i] or v < lower[i]:
            turn = -two_pi if v > upper[i] else two_pi
            if revolute[i] and lower[i] <= v + turn <= upper[i]:
                values[i] = v + turn
            else:
                saturated[i] = True
                limits[i] = upper[i] if v > upper[i] else lower[i]
                count += 1
    return count


@_jit
def _expand(x, var, n, couplings, offsets, coefficients, coupled_lower, coupled_upper):
    """Full q from the variables: q[var] = x, coupled joints = offset + c . q, clamped."""
    q = np.zeros(n)
    for j in range(var.shape[0]):
        q[var[j]] = x[j]
    for k in range(couplings.shape[0]):
        value = offsets[k] + coefficients[k] @ q
        q[couplings[k]] = min(max(value, coupled_lower[k]), coupled_upper[k])
    return q


POSE_OK, POSE_NOT_FINITE, POSE_ABSURD, POSE_NOT_RIGID = 0, 1, 2, 3


@_jit
def check_pose(pose, max_distance):
    """What is wrong with a 4x4 target pose, if anything (POSE_*): a value not finite, a position
    coordinate beyond max_distance, or not a rigid transform (|R R^T - I| > 1e-6 entry by entry,
    or a last row other than (0, 0, 0, 1)).  One compiled call instead of ~4 us of Python checks."""
    for i in range(4):
        for j in range(4):
            if not math.isfinite(pose[i, j]):
                return POSE_NOT_FINITE
    for i in range(3):
        if abs(pose[i, 3]) > max_distance:
            return POSE_ABSURD
    for i in range(3):
        for j in range(i, 3):
            dot = pose[i, 0] * pose[j, 0] + pose[i, 1] * pose[j, 1] + pose[i, 2] * pose[j, 2]
            if abs(dot - (1.0 if i == j else 0.0)) > 1e-6:
                return POSE_NOT_RIGID
    if pose[3, 0] != 0.0 or pose[3, 1] != 0.0 or pose[3, 2] != 0.0 or pose[3, 3] != 1.0:
        return POSE_NOT_RIGID
    return POSE_OK


@_jit
def pose_goal(pose, max_distance, rotation_mode, position, rotation):
    """``check_pose``, then, if the pose is fine, position = its translation and, by rotation_mode,
    rotation = its rotation (1), the rotation about z by its yaw, atan2(r10, r00) (2: a planar
    chain's target), or rotation untouched (0: position only).  Returns check_pose's code.  What
    ``base.parse_goal`` does to a 4x4 pose, in one call instead of ~2 us of Python."""
    problem = check_pose(pose, max_distance)
    if problem != POSE_OK:
        return problem
    for i in range(3):
        position[i] = pose[i, 3]
    if rotation_mode == 1:
        for i in range(3):
            for j in range(3):
                rotation[i, j] = pose[i, j]
    elif rotation_mode == 2:
        yaw = math.atan2(pose[1, 0], pose[0, 0])
        c, s = math.cos(yaw), math.sin(yaw)
        rotation[0, 0], rotation[0, 1], rotation[0, 2] = c, -s, 0.0
        rotation[1, 0], rotation[1, 1], rotation[1, 2] = s, c, 0.0
        rotation[2, 0], rotation[2, 1], rotation[2, 2] = 0.0, 0.0, 1.0
    return POSE_OK


@_jit
def clamp_finite(values, lower, upper, out):
    """out = values within [lower, upper] (as ``min(max(v, low), high)``), or False if a value is
    not finite (out is then unspecified).  A solve's seed in one call: ~1.5 us of Python at 3 joints."""
    for i in range(values.shape[0]):
        v = values[i]
        if not math.isfinite(v):
            return False
        if lower[i] > v:
            v = lower[i]
        if upper[i] < v:
            v = upper[i]
        out[i] = v
    return True


def pack_chain(
    fixed,
    motion,
    var,
    reduction,
    couplings,
    offsets,
    coefficients,
    coupled_lower,
    coupled_upper,
    lower,
    upper,
    revolute,
) -> tuple[np.ndarray, np.ndarray]:
    """A chain's arrays as one float and one int array: numba checks the type of every
    argument at every call (about 1 us each), so a call takes few arguments."""
    n, nv, k = motion.size, var.size, couplings.size
    floats = np.concatenate(
        [fixed.ravel(), reduction.ravel(), offsets, coefficients.ravel(), coupled_lower, coupled_upper, lower, upper]
    ).astype(float)
    ints = np.concatenate([[n, nv, k], motion, var, couplings, revolute.astype(np.int64)]).astype(np.int64)
    return floats, ints


def pack_goal(rows, weights, target, rotation, use_rotation: bool, planar: bool) -> tuple[np.ndarray, np.ndarray]:
    """A goal's arrays as one float array (target, rotation, weights; step settings
    appended per call) and one int array (m, flags, rows)."""
    floats = np.concatenate([target, rotation.ravel(), weights]).astype(float)
    ints = np.concatenate([[rows.size, int(use_rotation), int(planar)], rows]).astype(np.int64)
    return floats, ints


@_jit
def attempt_packed(chain_floats, chain_ints, goal_floats, goal_ints, settings, q0, max_steps, patience):
    """``attempt`` on packed arrays; settings = (lam2, adaptive, gain, tolerance2, orientation_tolerance)."""
    n, nv, k = chain_ints[0], chain_ints[1], chain_ints[2]
    at = 3
    motion = chain_ints[at : at + n]
    var = chain_ints[at + n : at + n + nv]
    couplings = chain_ints[at + n + nv : at + n + nv + k]
    revolute = chain_ints[at + n + nv + k : at + n + 2 * nv + k] != 0
    at = 0
    fixed = chain_floats[at : at + 16 * (n + 1)].reshape((n + 1, 4, 4))
    at += 16 * (n + 1)
    reduction = chain_floats[at : at + n * nv].reshape((n, nv))
    at += n * nv
    offsets = chain_floats[at : at + k]
    at += k
    coefficients = chain_floats[at : at + k * n].reshape((k, n))
    at += k * n
    coupled_lower, coupled_upper = chain_floats[at : at + k], chain_floats[at + k : at + 2 * k]
    at += 2 * k
    lower, upper = chain_floats[at : at + nv], chain_floats[at + nv : at + 2 * nv]
    m = goal_ints[0]
    rows = goal_ints[3 : 3 + m]
    target = goal_floats[0:3]
    rotation = goal_floats[3:12].reshape((3, 3))
    weights = goal_floats[12 : 12 + m]
    return attempt(
        fixed,
        motion,
        var,
        reduction,
        couplings,
        offsets,
        coefficients,
        coupled_lower,
        coupled_upper,
        lower,
        upper,
        revolute,
        rows,
        weights,
        target,
        rotation,
        goal_ints[1] != 0,
        goal_ints[2] != 0,
        q0,
        max_steps,
        settings[0],
        settings[1],
        settings[2],
        settings[3],
        settings[4],
        patience,
    )


@_jit
def attempt_measured(
    chain_floats,
    chain_ints,
    template,
    goal_ints,
    position,
    rotation,
    tolerance2,
    orientation_tolerance,
    q0,
    max_steps,
    patience,
    out,
):
    """``attempt_packed``, then what a result reports of its best q, in the same call (a solve that
    needs no restart makes one compiled call).  template: ``pack_goal``'s floats, then the settings
    of ``attempt_packed``, of which the goal's position (3,), rotation (3, 3) and the two tolerances
    are set here (in Python, a copy and four writes cost ~0.8 us).  out = (q (n), tool pose (4, 4)
    row by row, position error, orientation error, error vector: position rows (x, y for planar
    chains), then the rotation vector (its z for planar chains) when the goal has a rotation).
    Returns (converged, iterations, score)."""
    goal_floats = template.copy()
    for i in range(3):
        goal_floats[i] = position[i]
        for j in range(3):
            goal_floats[3 + 3 * i + j] = rotation[i, j]
    goal_floats[-2] = tolerance2
    goal_floats[-1] = orientation_tolerance
    q, converged, iterations, score = attempt_packed(
        chain_floats, chain_ints, goal_floats[:-5], goal_ints, goal_floats[-5:], q0, max_steps, patience
    )
    n = chain_ints[0]
    motion = chain_ints[3 : 3 + n]
    fixed = chain_floats[: 16 * (n + 1)].reshape((n + 1, 4, 4))
    has_rotation, planar = goal_ints[1] != 0, goal_ints[2] != 0
    R, p = np.empty((3, 3)), np.empty(3)
    jacobian, axes, points = np.empty((6, n)), np.empty((n, 3)), np.empty((n, 3))
    _pose_jacobian(fixed, motion, q, R, p, axes, points, jacobian)
    for i in range(n):
        out[i] = q[i]
    for i in range(3):
        for j in range(3):
            out[n + 4 * i + j] = R[i, j]
        out[n + 4 * i + 3] = p[i]
        out[n + 12 + i] = 0.0
    out[n + 15] = 1.0
    at = n + 18
    dims = 2 if planar else 3
    position2 = 0.0
    for i in range(dims):
        out[at + i] = goal_floats[i] - p[i]
        position2 += out[at + i] ** 2
    out[n + 16], out[n + 17] = math.sqrt(position2), 0.0
    if has_rotation:
        wx, wy, wz = _rotation_error(R, goal_floats[3:12].reshape((3, 3)))
        if planar:
            out[at + 2] = wz
            out[n + 17] = abs(wz)
        else:
            out[at + 3], out[at + 4], out[at + 5] = wx, wy, wz
            out[n + 17] = math.sqrt(wx * wx + wy * wy + wz * wz)
    return converged, iterations, score


@_jit
def attempt(
    fixed,
    motion,
    var,
    reduction,
    couplings,
    offsets,
    coefficients,
    coupled_lower,
    coupled_upper,
    lower,
    upper,
    revolute,
    rows,
    weights,
    target,
    rotation,
    use_rotation,
    planar,
    q0,
    max_steps,
    lam2,
    adaptive,
    gain,
    tolerance2,
    orientation_tolerance,
    patience,
):
    """One DLS descent from q0: (best q, converged, iterations, best score)."""
    n = motion.shape[0]
    m = rows.shape[0]
    nv = var.shape[0]
    reduced = couplings.shape[0] > 0
    project = reduced and nv == n  # 'project' update: every joint stepped, then the coupled ones overwritten
    jacobian = np.empty((6, n))
    R, p = np.empty((3, 3)), np.empty(3)
    axes, points = np.empty((n, 3)), np.empty((n, 3))
    full_error = np.empty(6)
    error, rest = np.empty(m), np.empty(m)
    jac_rows = np.empty((m, n))
    jac = np.empty((m, nv))
    work, y = np.empty((m, m)), np.empty(m)
    step = np.empty(nv)
    saturated = np.zeros(nv, dtype=np.bool_)
    limits = np.zeros(nv)
    x = q0[var].copy()
    q = q0.copy()
    best_q, best_score = q.copy(), math.inf
    stale = 0
    iteration = 0
    for iteration in range(max_steps + 1):
        _pose_jacobian(fixed, motion, q, R, p, axes, points, jacobian)
        ex, ey, ez = target[0] - p[0], target[1] - p[1], target[2] - p[2]
        pos2 = ex * ex + ey * ey + (0.0 if planar else ez * ez)
        wx = wy = wz = 0.0
        if use_rotation:
            wx, wy, wz = _rotation_error(R, rotation)
        ori = (abs(wz) if planar else math.sqrt(wx * wx + wy * wy + wz * wz)) if use_rotation else 0.0
        full_error[0], full_error[1], full_error[2] = ex, ey, ez
        full_error[3], full_error[4], full_error[5] = wx, wy, wz
        score = 0.0
        for r in range(m):
            error[r] = full_error[rows[r]] * weights[r]
            score += error[r] * error[r]
        if pos2 <= tolerance2 and ori <= orientation_tolerance:
            return q, True, iteration, score
        if score < best_score:
            stale = stale + 1 if score > 0.999 * best_score else 0
            best_q, best_score = q, score
        else:
            stale += 1
        if iteration == max_steps or (patience > 0 and stale >= patience):
            break
        if reduced and not project:  # J_r = J[rows] C
            for r in range(m):
                for c in range(n):
                    jac_rows[r, c] = jacobian[rows[r], c] * weights[r]
            for r in range(m):
                for j in range(nv):
                    total = 0.0
                    for c in range(n):
                        total += jac_rows[r, c] * reduction[c, j]
                    jac[r, j] = total
        else:
            for r in range(m):
                for c in range(n):
                    jac[r, c] = jacobian[rows[r], c] * weights[r]
        damping = lam2 + adaptive * score
        if not _damped_step(jac, error, damping, gain, work, y, step):
            break
        new = x + step
        if not np.isfinite(new.sum()):
            break
        saturated[:] = False
        if _wrap_or_saturate(new, lower, upper, revolute, saturated, limits):
            rest[:] = error
            for j in range(nv):
                if saturated[j]:
                    for r in range(m):
                        rest[r] -= jac[r, j] * (limits[j] - x[j])
                        jac[r, j] = 0.0
            if not _damped_step(jac, rest, damping, gain, work, y, step):
                break
            new = x + step
            if not np.isfinite(new.sum()):
                break
            for j in range(nv):
                if saturated[j]:
                    new[j] = limits[j]
            saturated[:] = False
            if _wrap_or_saturate(new, lower, upper, revolute, saturated, limits):
                for j in range(nv):
                    if saturated[j]:
                        new[j] = limits[j]
        x = new
        q = _expand(x, var, n, couplings, offsets, coefficients, coupled_lower, coupled_upper) if reduced else x
        if project:
            x = q.copy()
    return best_q, False, iteration, best_score


@_jit
def best_start(chain_floats, chain_ints, goal_floats, goal_ints, candidates):
    """Index of the candidate (rows of full joint vectors) with the least weighted task error:
    the restart choice of ``dls`` in one call instead of one Python FK per candidate."""
    n = chain_ints[0]
    motion = chain_ints[3 : 3 + n]
    fixed = chain_floats[: 16 * (n + 1)].reshape((n + 1, 4, 4))
    m = goal_ints[0]
    rows = goal_ints[3 : 3 + m]
    target = goal_floats[0:3]
    rotation = goal_floats[3:12].reshape((3, 3))
    weights = goal_floats[12 : 12 + m]
    use_rotation, planar = goal_ints[1] != 0, goal_ints[2] != 0
    jacobian = np.empty((6, n))
    R, p = np.empty((3, 3)), np.empty(3)
    axes, points = np.empty((n, 3)), np.empty((n, 3))
    full_error = np.empty(6)
    best, best_score = 0, math.inf
    for index in range(candidates.shape[0]):
        _pose_jacobian(fixed, motion, candidates[index], R, p, axes, points, jacobian)
        full_error[0], full_error[1], full_error[2] = target[0] - p[0], target[1] - p[1], target[2] - p[2]
        if planar:
            full_error[2] = 0.0
        full_error[3] = full_error[4] = full_error[5] = 0.0
        if use_rotation:
            full_error[3], full_error[4], full_error[5] = _rotation_error(R, rotation)
        score = 0.0
        for r in range(m):
            score += (full_error[rows[r]] * weights[r]) ** 2
        if score < best_score:
            best, best_score = index, score
    return best
