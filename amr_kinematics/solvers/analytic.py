"""Closed-form planar 2R inverse kinematics with both elbow branches (seed 001).

For links l1, l2 and a target at (x, y) in the base frame:
    cos q2 = (x^2 + y^2 - l1^2 - l2^2) / (2 l1 l2),  sin q2 = +-sqrt(1 - cos^2 q2)
    q2 = atan2(sin q2, cos q2)
    q1 = atan2(y, x) - atan2(l2 sin q2, l1 + l2 cos q2)
atan2 everywhere (the seed's arctan(y/x) lost the quadrant).  Theta offsets and a
planar tool offset fold into these angles.  Out of reach, the arm points at the
target stretched (too far) or folded (too close) and the result says so.
"""

from __future__ import annotations

import math

import numpy as np

from amr_util.geometry import wrap_angle

from ..chain import Chain
from ..errors import SolverNotApplicableError
from .base import IKResult, Solver, finish


def _geometry(chain: Chain) -> tuple[float, float, float, float]:
    """(l1, l2, offset1, offset2) with q1 = A - offset1, q2 = B - offset2 for the 2R angles A, B."""
    tool_x, tool_y = float(chain.tool[0, 3]), float(chain.tool[1, 3])
    far_x, far_y = float(chain.a[1]) + tool_x, tool_y  # tip in the frame before link 2's length
    return (
        float(chain.a[0]),
        math.hypot(far_x, far_y),
        float(chain.theta[0]),
        float(chain.theta[1]) + math.atan2(far_y, far_x),
    )


def _local(chain: Chain, point) -> tuple[float, float]:
    """Target in the base frame of the chain (x, y)."""
    (c, _, _, bx), (s, _, _, by) = chain.base[:2].tolist()
    dx, dy = float(point[0]) - bx, float(point[1]) - by
    return c * dx + s * dy, -s * dx + c * dy


def _fit(chain: Chain, q: list[float]) -> list[float] | None:
    """q moved by multiples of 2 pi into the limits, or None if impossible."""
    out = []
    for value, low, high in zip(q, chain.lower.tolist(), chain.upper.tolist(), strict=True):
        if not low <= value <= high:
            value = low + (value - low) % (2.0 * math.pi)
            if value > high:
                return None
        out.append(value)
    return out


def two_link_branches(chain: Chain, target) -> tuple[list[np.ndarray], bool]:
    """([elbow +, elbow -] solutions within limits, reachable), angles in [-pi, pi]
    where the limits allow.  Unreachable: ([closest configuration], False)."""
    solutions, reachable = _branches(chain, target)
    return [np.array(q) for q in solutions], reachable


def _branches(chain: Chain, target) -> tuple[list[list[float]], bool]:
    """``two_link_branches`` on plain floats."""
    l1, l2, offset1, offset2 = _geometry(chain)
    x, y = _local(chain, target)
    r2 = x * x + y * y
    cos_q2 = (r2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2) if l1 > 0 and l2 > 0 else math.inf
    reachable = -1.0 - 1e-12 <= cos_q2 <= 1.0 + 1e-12
    if not reachable:  # stretched towards the target, or folded back on it
        heading = math.atan2(y, x) if r2 > 0.0 else 0.0
        if cos_q2 > 1.0:  # too far: stretched
            angles = (heading, 0.0)
        elif l1 >= l2:  # too close, folded: the tip lies l1 - l2 along link 1
            angles = (heading, math.pi)
        else:  # folded with the longer second link: link 1 points away
            angles = (heading + math.pi, math.pi)
        q = [wrap_angle(angles[0] - offset1), wrap_angle(angles[1] - offset2)]
        fitted = _fit(chain, q)
        return [chain.clamp(q).tolist() if fitted is None else fitted], False
    cos_q2 = min(1.0, max(-1.0, cos_q2))
    solutions = []
    for sign in (1.0, -1.0):
        sin_q2 = sign * math.sqrt(1.0 - cos_q2 * cos_q2)
        b = math.atan2(sin_q2, cos_q2)
        a = math.atan2(y, x) - math.atan2(l2 * sin_q2, l1 + l2 * cos_q2)
        fitted = _fit(chain, [wrap_angle(a - offset1), wrap_angle(b - offset2)])
        if fitted is not None:
            solutions.append(fitted)
    return solutions, True


def joint_distance(chain: Chain, q, reference) -> float:
    """Distance in joint space, revolute differences wrapped to [-pi, pi]."""
    total = 0.0
    for value, ref, prismatic in zip(q, reference, chain.prismatic.tolist(), strict=True):
        diff = float(value) - float(ref)
        if not prismatic:
            diff = wrap_angle(diff)
        total += diff * diff
    return math.sqrt(total)


def _nearest(chain: Chain, candidates: list[list[float]], reference: list[float]) -> list[float]:
    """The candidate nearest the reference, shifted by 2 pi to continue it when the
    limits allow (so a path never jumps by a full turn)."""
    best = min(candidates, key=lambda q: joint_distance(chain, q, reference))
    continued = [r + wrap_angle(b - r) for b, r in zip(best, reference, strict=True)]
    return continued if chain.within_limits(continued) else best


class AnalyticSolver(Solver):
    name = "analytic"
    options = {}

    def check(self, chain, with_orientation=False) -> None:
        if not (chain.planar and chain.n == 2 and not chain.prismatic.any() and not chain.couplings):
            raise SolverNotApplicableError(
                f"analytic solves planar 2R chains only; chain '{chain.name}' is {chain.convention} with "
                f"{chain.n} joints ({', '.join(chain.types)})"
            )
        if with_orientation:
            raise SolverNotApplicableError("a 2R arm cannot choose its orientation: analytic takes a position only")

    def _solve(self, chain, goal, q0, request, configuration) -> IKResult:
        candidates, reachable = _branches(chain, goal.position)
        if not candidates:
            return finish(
                chain,
                goal,
                q0,
                request,
                solver=self.name,
                iterations=1,
                converged=False,
                message="reachable, but neither elbow branch fits the joint limits: seed returned",
            )
        q = np.array(_nearest(chain, candidates, q0.tolist()))
        message = "solved: branch nearest the seed" if reachable else "unreachable: closest configuration returned"
        return finish(
            chain,
            goal,
            q,
            request,
            solver=self.name,
            iterations=1,
            message=message,
            converged=None if reachable else False,
        )


def follow_path(chain: Chain, points, q_start=None) -> tuple[np.ndarray, np.ndarray]:
    """Joint positions (N, 2) along Cartesian points, each the branch nearest the
    previous solution, and a reachable mask (N,).  The first point takes the branch
    nearest ``q_start`` (default: elbow +)."""
    AnalyticSolver().check(chain)
    points = np.asarray(points, dtype=float)
    path, mask = [], []
    previous = None if q_start is None else chain.check_q(q_start, "q_start").tolist()
    for point in points:
        candidates, reachable = _branches(chain, point)
        if not candidates:
            candidates, reachable = [previous if previous is not None else chain.clamp(np.zeros(2)).tolist()], False
        q = candidates[0] if previous is None else _nearest(chain, candidates, previous)
        path.append(q)
        mask.append(reachable)
        previous = q
    return np.array(path), np.array(mask)
