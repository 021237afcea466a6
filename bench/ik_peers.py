"""ikpy and roboticstoolbox-python models built from our chains, for bench_ik.py.

Both are optional (the ``bench`` extras): ``peers()`` lists the ones that import,
and why the others do not.  Every model is checked against our FK before use,
so the peers solve exactly the same targets.
"""

from __future__ import annotations

import importlib
import math
import warnings

import numpy as np

from amr_kinematics.chain import MOTION_ROT_Z, MOTION_TRANS_X, Chain
from amr_kinematics.transforms import matrix_rpy


def peers() -> tuple[dict, dict]:
    """({name: factory(chain) -> Peer}, {name: reason it is missing})."""
    available, missing = {}, {}
    try:
        importlib.import_module("ikpy")
        available["ikpy"] = IkpyPeer
    except Exception as exc:  # report any import failure as is
        missing["ikpy"] = f"{type(exc).__name__}: {exc}"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            importlib.import_module("roboticstoolbox")
        available["rtb_LM"] = RtbPeer
        available["rtb_NR"] = RtbNRPeer
    except Exception as exc:
        missing["rtb"] = f"{type(exc).__name__}: {exc}"
    try:
        importlib.import_module("pytracik")
        available["tracik"] = TracIkPeer
    except Exception as exc:
        missing["tracik"] = f"{type(exc).__name__}: {exc}"
    return available, missing


class IkpyPeer:
    """ikpy 4 chain: one URDF-style link per joint (fixed origin, then z motion)."""

    def __init__(self, chain: Chain) -> None:
        from ikpy.chain import Chain as IkChain
        from ikpy.link import OriginLink, URDFLink

        fixed, motions = chain.segments()
        links = [OriginLink()]
        for i, (frame, motion) in enumerate(zip(fixed[:-1], motions, strict=True)):
            if motion == MOTION_TRANS_X:
                raise NotImplementedError("planar prismatic joints are not modelled for ikpy")
            axis = [0.0, 0.0, 1.0]
            kwargs = {"rotation": axis} if motion == MOTION_ROT_Z else {"translation": axis, "joint_type": "prismatic"}
            links.append(
                URDFLink(
                    name=chain.joint_names[i],
                    origin_translation=frame[:3, 3],
                    origin_orientation=matrix_rpy(frame[:3, :3]),
                    bounds=(chain.lower[i], chain.upper[i]),
                    **kwargs,
                )
            )
        links.append(
            URDFLink(
                name="tool",
                origin_translation=fixed[-1][:3, 3],
                origin_orientation=matrix_rpy(fixed[-1][:3, :3]),
                joint_type="fixed",
            )
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self.model = IkChain(links, active_links_mask=[False] + [True] * chain.n + [False])
        self.n = chain.n
        _check_model(chain, lambda q: self.model.forward_kinematics(self._full(q)))

    def _full(self, q) -> np.ndarray:
        return np.concatenate([[0.0], q, [0.0]])

    def solve(self, target: np.ndarray, seed: np.ndarray, with_orientation: bool) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if with_orientation:
                q = self.model.inverse_kinematics(
                    target[:3, 3], target[:3, :3], orientation_mode="all", initial_position=self._full(seed)
                )
            else:
                q = self.model.inverse_kinematics(target[:3, 3], initial_position=self._full(seed))
        return np.asarray(q)[1:-1], math.nan  # ikpy (scipy) does not report its iterations


class RtbPeer:
    """roboticstoolbox model as an elementary-transform sequence (ETS) of the same
    F_0 M_1 F_1 ... M_n F_n product, solved by its C++ Levenberg-Marquardt ``ik_LM``
    with joint limits.  (A DHRobot with a tool would be the natural model, but in
    rtb 1.5.0 ik_LM diverges on a DHRobot whose tool is not identity, although its
    fkine is right; the ETS form avoids the trailing SE3.)"""

    def _build(self, chain: Chain) -> None:
        from roboticstoolbox import ET, ETS

        fixed, motions = chain.segments()
        elements = []
        for i, motion in enumerate(motions):
            elements += _fixed_elements(ET, fixed[i])
            limits = [chain.lower[i], chain.upper[i]]
            joint = {MOTION_ROT_Z: ET.Rz, MOTION_TRANS_X: ET.tx}.get(motion, ET.tz)
            elements.append(joint(jindex=i, qlim=limits))
        elements += _fixed_elements(ET, fixed[-1])
        self.model = ETS(elements)
        _check_model(chain, lambda q: self.model.fkine(q).A)

    method = "ik_LM"

    def __init__(self, chain: Chain) -> None:
        self.planar = chain.planar
        self._build(chain)

    def solve(self, target: np.ndarray, seed: np.ndarray, with_orientation: bool) -> tuple[np.ndarray, float]:
        """(q, iterations over all its searches)."""
        if self.planar:
            mask = np.array([1.0, 1.0, 0.0, 0.0, 0.0, 1.0 if with_orientation else 0.0])
        else:
            mask = None if with_orientation else np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
        # tol bounds E = 0.5 e^T W e: 1e-12 keeps |e| below 1.5e-6, inside our 1e-5 check;
        # rtb 1.5.0 binding: joint_limits must be an int and q0 a writable array
        solution = getattr(self.model, self.method)(
            target, q0=np.array(seed, dtype=float), tol=1e-12, mask=mask, joint_limits=1
        )
        return np.asarray(solution.q), float(solution.iterations)


class RtbNRPeer(RtbPeer):
    """The same model solved by rtb's C++ Newton-Raphson ``ik_NR``."""

    method = "ik_NR"


class TracIkPeer:
    """TRAC-IK (C++, KDL + SQP) through pytracik 0.0.3, on a URDF written from our chain's
    segments; full pose only (the binding takes no per-axis bounds), the same 5 ms budget
    and 1e-5 epsilon as ours, SolveType Speed."""

    modes = ("pose",)

    def __init__(self, chain: Chain) -> None:
        import pytracik

        self.pytracik = pytracik
        self.solver = pytracik.TRAC_IK("base", "tip", chain_urdf(chain), 0.005, 1e-5, pytracik.SolveType.Speed)
        _check_model(chain, lambda q: pytracik.fk(self.solver, np.asarray(q, dtype=float)))

    def solve(self, target: np.ndarray, seed: np.ndarray, with_orientation: bool) -> tuple[np.ndarray, float]:
        from transforms3d.quaternions import mat2quat

        w, x, y, z = mat2quat(target[:3, :3])
        result = self.pytracik.ik(self.solver, np.array(seed, dtype=float), *target[:3, 3], x, y, z, w)
        return np.asarray(result[1:]), math.nan  # result[0] is TRAC-IK's status; no iteration count


def chain_urdf(chain: Chain) -> str:
    """A URDF of the chain's segments F_0 M_1 F_1 ... M_n F_n: one joint about (or along) z per
    motion, its origin F_{i-1}; the last F_n a fixed joint to the link "tip"."""
    fixed, motions = chain.segments()

    def origin(frame: np.ndarray) -> str:
        values = [*frame[:3, 3].tolist(), *matrix_rpy(frame[:3, :3])]
        return '<origin xyz="{!r} {!r} {!r}" rpy="{!r} {!r} {!r}"/>'.format(*map(float, values))

    parts, parent = ['<robot name="chain"><link name="base"/>'], "base"
    for i, motion in enumerate(motions):
        if motion == MOTION_TRANS_X:
            raise NotImplementedError("planar prismatic joints are not modelled for TRAC-IK")
        kind = "revolute" if motion == MOTION_ROT_Z else "prismatic"
        parts.append(
            f'<link name="l{i}"/><joint name="{chain.joint_names[i]}" type="{kind}">'
            f'<parent link="{parent}"/><child link="l{i}"/>{origin(fixed[i])}<axis xyz="0 0 1"/>'
            f'<limit lower="{float(chain.lower[i])!r}" upper="{float(chain.upper[i])!r}" effort="1" '
            f'velocity="1"/></joint>'
        )
        parent = f"l{i}"
    parts.append(
        f'<link name="tip"/><joint name="tool" type="fixed"><parent link="{parent}"/>'
        f'<child link="tip"/>{origin(fixed[-1])}</joint></robot>'
    )
    return "".join(parts)


def _fixed_elements(ET, frame: np.ndarray) -> list:
    """Constant ETs for a 4x4: translation then Rz(yaw) Ry(pitch) Rx(roll), zeros dropped."""
    roll, pitch, yaw = matrix_rpy(frame[:3, :3])
    candidates = [
        (ET.tx, frame[0, 3]),
        (ET.ty, frame[1, 3]),
        (ET.tz, frame[2, 3]),
        (ET.Rz, yaw),
        (ET.Ry, pitch),
        (ET.Rx, roll),
    ]
    return [make(value) for make, value in candidates if abs(value) > 1e-15]


def _check_model(chain: Chain, fk) -> None:
    """The peer's FK must equal ours on a few random configurations."""
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = rng.uniform(chain.lower, chain.upper)
        ours, theirs = chain.fk(q).tool, np.asarray(fk(q))
        if not np.allclose(ours, theirs, atol=1e-9):
            raise RuntimeError(f"peer model of {chain.name} disagrees with our FK by {np.abs(ours - theirs).max():.3g}")


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """Rotation angle between two 3x3 rotations."""
    return math.acos(min(1.0, max(-1.0, (np.trace(a.T @ b) - 1.0) / 2.0)))
