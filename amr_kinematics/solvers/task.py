"""Partial poses: which task-space rows a solve drives to zero.

A full pose asks 6 things (x, y, z, rotation about x, y, z); a SCARA can give
position and yaw (4), a 5-joint arm position and the direction its tool points
(5).  A ``Task`` says what is wanted:

- ``weights`` (wx, wy, wz, wrx, wry, wrz) >= 0 scale the rows of the error
  e = (p_target - p, rotation vector taking R to R_target) and of the Jacobian;
  a zero weight frees that axis (base frame).  Rotation weights need a target
  orientation.
- ``tool_axis`` a (tool frame) and ``direction`` d (base frame): the tool axis
  must point along d, whatever the roll about it.  With a_w = R a,
      angle = atan2(|a_w x d|, a_w . d),  w = angle (a_w x d) / |a_w x d|
  and since d(a_w)/dt = omega x a_w, only omega's components across a_w move
  it: two rows b_i . w and b_i . J_omega for a basis b_1, b_2 of the plane
  normal to a_w (replacing the three rotation rows).

Converged when the weighted axes' position error <= tolerance and the
orientation error (weighted rotation rows, or the pointing angle) <=
orientation tolerance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidRequestError
from ..transforms import rotation_error


@dataclass(frozen=True)
class Task:
    weights: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
    tool_axis: tuple[float, float, float] | None = None
    direction: tuple[float, float, float] | None = None

    @property
    def uses_rotation_target(self) -> bool:
        return self.tool_axis is None and any(self.weights[3:])


def parse_task(weights=None, pointing=None) -> Task | None:
    """A checked Task from 6 weights and/or 6 pointing values (tool axis, direction);
    None when both are empty (today's position / full pose behaviour)."""
    weights = [] if weights is None else list(weights)
    pointing = [] if pointing is None else list(pointing)
    if not weights and not pointing:
        return None
    if weights:
        if len(weights) != 6 or not all(isinstance(w, (int, float)) and math.isfinite(w) and w >= 0.0 for w in weights):
            raise InvalidRequestError(
                f"task weights need 6 finite values >= 0 (x, y, z, rot x, rot y, rot z), got {weights!r}"
            )
        if not any(weights):
            raise InvalidRequestError("task weights are all zero: nothing to solve")
    else:
        weights = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
    if not pointing:
        return Task(tuple(float(w) for w in weights))
    if len(pointing) != 6 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in pointing):
        raise InvalidRequestError(
            f"pointing needs 6 finite values (tool axis x, y, z, direction x, y, z), got {pointing!r}"
        )
    units = []
    for name, vector in (("tool axis", pointing[:3]), ("direction", pointing[3:])):
        vector = np.array(vector, dtype=float)
        scale = float(np.abs(vector).max())  # divided first: the norm of (1e200, 0, 0) would overflow
        if scale == 0.0 or scale * float(np.linalg.norm(vector / scale)) < 1e-9:
            raise InvalidRequestError(f"pointing: the {name} is a zero vector")
        units.append(vector / scale / np.linalg.norm(vector / scale))
    return Task(tuple(float(w) for w in weights), tuple(units[0].tolist()), tuple(units[1].tolist()))


def _normal_basis(a: np.ndarray) -> np.ndarray:
    """(2, 3): two unit vectors normal to a and to each other."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b1 = np.cross(a, helper)
    b1 /= np.linalg.norm(b1)
    return np.array([b1, np.cross(a, b1)])


def task_rows(
    task: Task,
    target: np.ndarray,
    rotation: np.ndarray | None,
    position: np.ndarray,
    tool_rotation: np.ndarray,
    jacobian: np.ndarray | None,
):
    """(error rows, Jacobian rows or None, position error, orientation error) at one pose.

    ``jacobian`` is the 6 x n geometric Jacobian (v rows, then omega rows)."""
    weights = task.weights
    position_axes = [i for i in range(3) if weights[i] > 0.0]
    dp = target - position
    rows = [weights[i] * dp[i] for i in position_axes]
    jac_rows = [weights[i] * jacobian[i] for i in position_axes] if jacobian is not None else None
    position_error = math.sqrt(sum(dp[i] * dp[i] for i in position_axes))
    orientation_error = 0.0
    if task.tool_axis is not None:
        a = tool_rotation @ np.array(task.tool_axis)
        d = np.array(task.direction)
        cross = np.cross(a, d)
        sine, cosine = float(np.linalg.norm(cross)), float(a @ d)
        orientation_error = math.atan2(sine, cosine)
        basis = _normal_basis(a)
        if sine > 1e-12:
            w = cross * (orientation_error / sine)
        else:  # aligned (w = 0) or opposite (any normal axis turns it round)
            w = basis[0] * orientation_error
        rows += (basis @ w).tolist()
        if jac_rows is not None:
            jac_rows += list(basis @ jacobian[3:])
    elif task.uses_rotation_target:
        w = rotation_error(*tool_rotation.ravel().tolist(), *rotation.ravel().tolist())
        axes = [i for i in range(3) if weights[3 + i] > 0.0]
        rows += [weights[3 + i] * w[i] for i in axes]
        if jac_rows is not None:
            jac_rows += [weights[3 + i] * jacobian[3 + i] for i in axes]
        orientation_error = math.sqrt(sum(w[i] * w[i] for i in axes))
    return np.array(rows), (np.array(jac_rows) if jac_rows is not None else None), position_error, orientation_error
