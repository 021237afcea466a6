"""Serial chains as data: joints, DH or planar parameters, limits, couplings.

Three conventions, joint value q added to theta (revolute) or to the length
(prismatic: d for DH, a for planar):

- ``standard_dh``:  A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)
- ``modified_dh`` (Craig): A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i),
  i.e. the row of joint i holds alpha_{i-1} and a_{i-1}
- ``planar`` (the ULL report's CCD robots): A_i = Rz(theta_i) Tx(a_i) in the XY plane
- ``urdf`` (``amr_kinematics.urdf``): A_i = F_i M_i(q_i) with a constant F_i (the
  joint's origin and fixed joints before it, turned so the joint axis is z) and
  M_i = Rz (revolute) or Tz (prismatic); the tool transform holds F_n

Pose of the tool: T = base * A_1 * ... * A_n * tool.  Units are SI (REP 103).

A coupling makes a joint follow the others, q_k = offset + sum_i c_i q_i (seed
004 keeps its tool pointing down with q5 = -pi/2 - q2 - q3 - q4).  Solvers move
the independent joints and derive the coupled ones.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .errors import ChainConfigError, InvalidRequestError
from .transforms import rot_x, rot_z, trans

REVOLUTE = "revolute"
PRISMATIC = "prismatic"
JOINT_TYPES = (REVOLUTE, PRISMATIC)
STANDARD_DH = "standard_dh"
MODIFIED_DH = "modified_dh"
PLANAR = "planar"
URDF = "urdf"
CONVENTIONS = (STANDARD_DH, MODIFIED_DH, PLANAR)  # of DH tables; URDF chains come from amr_kinematics.urdf

# Axes along/about which a joint moves in its own frame, for the fast kernel.
MOTION_ROT_Z, MOTION_TRANS_Z, MOTION_TRANS_X = "rz", "tz", "tx"


@dataclass(frozen=True)
class Coupling:
    """q[joint] = offset + coefficients . q (coefficients of coupled joints are 0)."""

    joint: int
    offset: float
    coefficients: np.ndarray

    def value(self, q: np.ndarray) -> float:
        return self.offset + float(self.coefficients @ q)


@dataclass(frozen=True)
class FKResult:
    """Tool pose and every joint frame, all in the world (base parent) frame.

    ``frames[0]`` is the base frame, ``frames[i]`` the frame after joint i;
    ``tool`` is ``frames[-1] @ chain.tool``.
    """

    tool: np.ndarray
    frames: np.ndarray

    @property
    def position(self) -> np.ndarray:
        return self.tool[:3, 3]

    @property
    def origins(self) -> np.ndarray:
        """(n + 2, 3): base origin, each joint frame origin, tool point."""
        return np.vstack([self.frames[:, :3, 3], self.tool[:3, 3]])


def _as_float_array(name: str, key: str, values, length: int | None = None) -> np.ndarray:
    try:
        array = np.array(values, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise ChainConfigError(name, key, f"expected a list of numbers, got {values!r}") from exc
    if length is not None and array.size != length:
        raise ChainConfigError(name, key, f"has {array.size} values, the chain has {length} joints")
    if not np.all(np.isfinite(array)):
        raise ChainConfigError(name, key, f"values must be finite, got {array.tolist()}")
    return array


def _check_transform(name: str, key: str, matrix, planar: bool) -> np.ndarray:
    t = np.array(matrix, dtype=float)
    if t.shape != (4, 4) or not np.all(np.isfinite(t)):
        raise ChainConfigError(name, key, "must be a finite 4x4 homogeneous transform")
    r = t[:3, :3]
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-9) or not np.allclose(t[3], (0, 0, 0, 1)):
        raise ChainConfigError(name, key, "rotation part is not orthonormal")
    if planar and abs(r[2, 2] - 1.0) > 1e-9:
        raise ChainConfigError(name, key, "a planar chain's transform may only rotate about z")
    return t


class Chain:
    """An immutable serial chain; see the module docstring for the conventions."""

    def __init__(
        self,
        name: str,
        convention: str,
        joint_names: Sequence[str],
        types: Sequence[str],
        *,
        theta: Sequence[float],
        a: Sequence[float],
        d: Sequence[float] | None = None,
        alpha: Sequence[float] | None = None,
        lower: Sequence[float],
        upper: Sequence[float],
        base=None,
        tool=None,
        couplings: Sequence[Coupling] = (),
        joint_origins: Sequence[np.ndarray] | None = None,
    ) -> None:
        """``joint_origins`` (F_i, one 4x4 per joint) only with convention ``urdf``, whose
        DH parameters must then be zeros."""
        if convention == URDF:
            if joint_origins is None or len(joint_origins) != len(types):
                raise ChainConfigError(name, "joint_origins", "a urdf chain needs one origin transform per joint")
            self.joint_origins = tuple(_check_transform(name, "joint_origins", f, False) for f in joint_origins)
            for f in self.joint_origins:
                f.setflags(write=False)
        elif joint_origins is not None:
            raise ChainConfigError(name, "joint_origins", "joint origins belong to urdf chains only")
        elif convention not in CONVENTIONS:
            raise ChainConfigError(
                name, "convention", f"unknown convention {convention!r}, expected one of {CONVENTIONS}"
            )
        n = len(types)
        if n == 0:
            raise ChainConfigError(name, "types", "a chain needs at least one joint")
        for t in types:
            if t not in JOINT_TYPES:
                raise ChainConfigError(name, "types", f"unknown joint type {t!r}, expected 'revolute' or 'prismatic'")
        if len(joint_names) != n:
            raise ChainConfigError(name, "joint_names", f"has {len(joint_names)} names, the chain has {n} joints")
        if len(set(joint_names)) != n:
            raise ChainConfigError(name, "joint_names", "joint names must be unique")
        planar = convention == PLANAR
        if convention == URDF:
            d, alpha = np.zeros(n), np.zeros(n)
        if planar and (d is not None or alpha is not None):
            raise ChainConfigError(name, "d" if d is not None else "alpha", "planar chains take theta and a only")
        if not planar and (d is None or alpha is None):
            raise ChainConfigError(name, "d" if d is None else "alpha", "DH chains need d, theta, a and alpha")
        self.name = name
        self.convention = convention
        self.joint_names = tuple(joint_names)
        self.types = tuple(types)
        self.theta = _as_float_array(name, "theta", theta, n)
        self.a = _as_float_array(name, "a", a, n)
        self.d = np.zeros(n) if planar else _as_float_array(name, "d", d, n)
        self.alpha = np.zeros(n) if planar else _as_float_array(name, "alpha", alpha, n)
        self.lower = _as_float_array(name, "lower", lower, n)
        self.upper = _as_float_array(name, "upper", upper, n)
        bad = np.nonzero(self.lower > self.upper)[0]
        if bad.size:
            i = int(bad[0])
            raise ChainConfigError(
                name, "lower", f"joint '{joint_names[i]}' has lower {self.lower[i]} > upper {self.upper[i]}"
            )
        self.base = _check_transform(name, "base", np.eye(4) if base is None else base, planar)
        self.tool = _check_transform(name, "tool", np.eye(4) if tool is None else tool, planar)
        self._lower, self._upper = self.lower.tolist(), self.upper.tolist()
        self.prismatic = np.array([t == PRISMATIC for t in types])
        self.couplings = tuple(self._checked_couplings(couplings))
        coupled = {c.joint for c in self.couplings}
        self.free = np.array([i for i in range(n) if i not in coupled], dtype=int)
        if self.free.size == 0:
            raise ChainConfigError(name, "coupled_joint", "every joint is coupled: nothing left to move")
        for array in (
            self.theta,
            self.a,
            self.d,
            self.alpha,
            self.lower,
            self.upper,
            self.base,
            self.tool,
            self.prismatic,
            self.free,
        ):
            array.setflags(write=False)
        from .kernel import build_kernel  # here, not at a first solve's expense

        self.kernel = build_kernel(self)

    def _checked_couplings(self, couplings: Sequence[Coupling]):
        n = self.n
        coupled = [c.joint for c in couplings]
        if len(set(coupled)) != len(coupled):
            raise ChainConfigError(self.name, "coupled_joint", "a joint is coupled twice")
        for c in couplings:
            if not 0 <= c.joint < n:
                raise ChainConfigError(self.name, "coupled_joint", f"joint index {c.joint} is outside the chain")
            coefficients = _as_float_array(self.name, "coupling_coefficients", c.coefficients, n)
            if not math.isfinite(c.offset):
                raise ChainConfigError(self.name, "coupling_offset", "offset must be finite")
            if any(coefficients[j] != 0.0 for j in coupled):
                raise ChainConfigError(
                    self.name, "coupling_coefficients", "a coupled joint may only depend on independent joints"
                )
            coefficients.setflags(write=False)
            yield Coupling(c.joint, float(c.offset), coefficients)

    # --- shape and limits -------------------------------------------------------------
    @property
    def n(self) -> int:
        return len(self.types)

    @property
    def planar(self) -> bool:
        return self.convention == PLANAR

    @property
    def can_orient(self) -> bool:
        """Whether an orientation target is meaningful: yaw for planar chains with
        >= 3 independent joints, full orientation for spatial chains with >= 6."""
        return self.free.size >= (3 if self.planar else 6)

    def __repr__(self) -> str:
        return f"Chain({self.name!r}, {self.convention}, {self.n} joints)"

    def check_q(self, q, what: str = "joint vector") -> np.ndarray:
        """q as a float array of length n, or InvalidRequestError."""
        return np.array(self._checked_values(q, what))

    def checked_clamp(self, q, what: str = "joint vector") -> np.ndarray:
        """``clamp(check_q(q))`` with one conversion of the values (a solve's seed)."""
        return self._clamped(self._checked_values(q, what))

    def _checked_values(self, q, what: str) -> list:
        try:
            array = np.array(q, dtype=float).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise InvalidRequestError(f"{what} must be numbers, got {q!r}") from exc
        if array.size != self.n:
            raise InvalidRequestError(f"{what} has {array.size} values, chain '{self.name}' has {self.n} joints")
        values = array.tolist()
        if not all(map(math.isfinite, values)):
            raise InvalidRequestError(f"{what} must be finite, got {values}")
        return values

    def clamp(self, q) -> np.ndarray:
        """q within the limits (on floats: numpy's per-call overhead dominates at n <= 10)."""
        return self._clamped(q.tolist() if isinstance(q, np.ndarray) else [float(v) for v in q])

    def _clamped(self, values: list) -> np.ndarray:
        return np.array([min(max(v, low), high) for v, low, high in zip(values, self._lower, self._upper, strict=True)])

    def within_limits(self, q, tolerance: float = 0.0) -> bool:
        values = q.tolist() if isinstance(q, np.ndarray) else [float(v) for v in q]
        return len(values) == self.n and all(
            low - tolerance <= v <= high + tolerance
            for v, low, high in zip(values, self._lower, self._upper, strict=True)
        )

    def couplings_hold(self, q, tolerance: float = 1e-9) -> bool:
        """Whether every coupled joint equals its formula (not clipped by its limits)."""
        q = np.asarray(q, dtype=float)
        return all(abs(q[c.joint] - c.value(q)) <= tolerance for c in self.couplings)

    def apply_coupling(self, q) -> np.ndarray:
        """q with every coupled joint set from the independent ones (then clamped)."""
        q = np.array(q, dtype=float)
        for c in self.couplings:
            q[c.joint] = min(max(c.value(q), self.lower[c.joint]), self.upper[c.joint])
        return q

    # --- reference forward kinematics (numpy, readable) ----------------------------
    def joint_transform(self, i: int, q_i: float) -> np.ndarray:
        """A_i(q_i) for joint i in this chain's convention."""
        theta, d, a, alpha = self.theta[i], self.d[i], self.a[i], self.alpha[i]
        if self.prismatic[i]:
            a, d = (a + q_i, d) if self.planar else (a, d + q_i)
        else:
            theta = theta + q_i
        if self.convention == STANDARD_DH:
            return rot_z(theta) @ trans(z=d) @ trans(x=a) @ rot_x(alpha)
        if self.convention == MODIFIED_DH:
            return rot_x(alpha) @ trans(x=a) @ rot_z(theta) @ trans(z=d)
        if self.convention == URDF:
            return self.joint_origins[i] @ (trans(z=q_i) if self.prismatic[i] else rot_z(q_i))
        return rot_z(theta) @ trans(x=a)

    def fk(self, q) -> FKResult:
        """Tool pose and all joint frames for joint vector q (coupling not applied)."""
        q = self.check_q(q)
        frames = np.empty((self.n + 1, 4, 4))
        frames[0] = self.base
        for i in range(self.n):
            frames[i + 1] = frames[i] @ self.joint_transform(i, q[i])
        return FKResult(tool=frames[-1] @ self.tool, frames=frames)

    def jacobian(self, q) -> np.ndarray:
        """Geometric Jacobian (6 x n) of the tool point, world frame: rows (v, w).

        Revolute column: (z_i x (p_tool - o_i), z_i); prismatic: (u_i, 0), with z_i,
        o_i the joint axis and a point on it, u_i the sliding direction.
        """
        result = self.fk(q)
        p_tool = result.tool[:3, 3]
        jac = np.zeros((6, self.n))
        for i in range(self.n):
            # The frame in which joint i moves: before A_i for standard DH / planar,
            # after it for modified DH and URDF (the joint acts on the frame's own z).
            frame = result.frames[i + 1] if self.convention in (MODIFIED_DH, URDF) else result.frames[i]
            if self.prismatic[i]:
                # planar prismatic slides along x_i (after rotation theta_i)
                jac[:3, i] = result.frames[i + 1][:3, 0] if self.planar else frame[:3, 2]
            else:
                z = frame[:3, 2]
                jac[:3, i] = np.cross(z, p_tool - frame[:3, 3])
                jac[3:, i] = z
        return jac

    # --- fast path ----------------------------------------------------------------------
    def segments(self) -> tuple[list[np.ndarray], list[str]]:
        """The chain as F_0 M_1(q_1) F_1 ... M_n(q_n) F_n with constant F_i and
        elementary motions M_i in {Rz, Tz, Tx}: the form the fast kernel is built from."""
        pre, post, motions = [], [], []
        for i in range(self.n):
            theta, d, a, alpha = self.theta[i], self.d[i], self.a[i], self.alpha[i]
            if self.convention == STANDARD_DH:
                fixed = trans(z=d) @ trans(x=a) @ rot_x(alpha)
                pre.append(np.eye(4) if not self.prismatic[i] else rot_z(theta))
                post.append(rot_z(theta) @ fixed if not self.prismatic[i] else fixed)
                motions.append(MOTION_TRANS_Z if self.prismatic[i] else MOTION_ROT_Z)
            elif self.convention == URDF:
                pre.append(self.joint_origins[i])
                post.append(np.eye(4))
                motions.append(MOTION_TRANS_Z if self.prismatic[i] else MOTION_ROT_Z)
            elif self.convention == MODIFIED_DH:
                pre.append(rot_x(alpha) @ trans(x=a) @ rot_z(theta) @ trans(z=d))
                post.append(np.eye(4))
                motions.append(MOTION_TRANS_Z if self.prismatic[i] else MOTION_ROT_Z)
            elif self.prismatic[i]:
                pre.append(rot_z(theta))
                post.append(trans(x=a))
                motions.append(MOTION_TRANS_X)
            else:
                pre.append(np.eye(4))
                post.append(rot_z(theta) @ trans(x=a))
                motions.append(MOTION_ROT_Z)
        fixed = [self.base @ pre[0]]
        fixed += [post[i] @ pre[i + 1] for i in range(self.n - 1)]
        fixed.append(post[-1] @ self.tool)
        return fixed, motions
