"""Per-chain forward kinematics and Jacobian compiled to straight-line scalar code.

A solver calls FK and the Jacobian every iteration on 2-7 joints, where numpy's
per-call overhead (about 1 us per tiny array operation) dominates the arithmetic.
So, once per chain, we write the product F_0 M_1(q_1) F_1 ... M_n(q_n) F_n
(``Chain.segments``) out as Python float arithmetic with every constant folded:
zeros and ones of the DH matrices vanish from the code.  The result is checked
against the readable numpy reference (``Chain.fk`` / ``Chain.jacobian``) in tests.

Frame update rules used by the generator (R = [x y z] columns, p origin):
  T <- T F      R' = R F_R,  p' = R F_p + p
  T <- T Rz(q)  x' = c x + s y,  y' = c y - s x       (c, s = cos q, sin q)
  T <- T Tz(q)  p' = p + q z;    T <- T Tx(q)  p' = p + q x
Jacobian columns at the tool point p_e: revolute (z_i x (p_e - o_i), z_i),
prismatic (u_i, 0).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass

from .chain import MOTION_ROT_Z, MOTION_TRANS_X

_SNAP = 1e-12  # constants this close to 0 or +-1 are taken as exact (cos(pi/2) = 6e-17)

Value = float | str  # a folded constant, or a local's name with an optional "-"


@dataclass(frozen=True)
class Kernel:
    """Generated functions of the joint vector q (a list of floats).

    position(q)          -> (x, y, z)
    pose(q)              -> (x, y, z, r00, r01, r02, r10, r11, r12, r20, r21, r22)
    position_jacobian(q) -> (x, y, z, jx, jy, jz)            rows jx.. as lists of n floats
    pose_jacobian(q)     -> (x, y, z, r00..r22, J)   J: the 6 x n Jacobian row-major in one list
    """

    position: Callable
    pose: Callable
    position_jacobian: Callable
    pose_jacobian: Callable
    source: str


def _snap(x: float) -> float:
    for exact in (0.0, 1.0, -1.0):
        if abs(x - exact) < _SNAP:
            return exact
    return float(x)


class _Writer:
    """Emits assignments of sums of products of atoms, folding constants."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.count = 0

    def combine(self, terms: list[tuple[Value, Value]], constant: float = 0.0) -> Value:
        """sum(a * b for a, b in terms) + constant, as a constant or a new local."""
        parts: list[str] = []
        for a, b in terms:
            if isinstance(a, float) and isinstance(b, float):
                constant += a * b
                continue
            if isinstance(a, str) and isinstance(b, float):
                a, b = b, a
            if a == 0.0:
                continue
            if isinstance(a, float):
                factor = b if a == 1.0 else (f"-{b}" if a == -1.0 else f"{a!r}*{b}")
            else:
                factor = f"{a}*{b}"
            parts.append(factor)
        constant = _snap(constant) if not parts else constant
        if not parts:
            return constant
        if constant != 0.0:
            parts.append(repr(constant))
        if len(parts) == 1 and _is_atom(parts[0]):
            return parts[0].replace("--", "")
        expression = " + ".join(parts).replace("+ -", "- ")
        self.count += 1
        name = f"v{self.count}"
        self.lines.append(f"    {name} = {expression}")
        return name


def _is_atom(text: str) -> bool:
    return text.lstrip("-").isidentifier()


def _eliminate_dead(lines: list[str], result: str) -> list[str]:
    """Drop assignments whose value is never used (e.g. rotation in ``position``)."""
    live = set(re.findall(r"[A-Za-z_]\w*", result))
    kept = []
    for line in reversed(lines):
        target, expression = line.split(" = ", 1)
        if target.strip() in live:
            live.update(re.findall(r"[A-Za-z_]\w*", expression))
            kept.append(line)
    return kept[::-1]


def _text(value: Value) -> str:
    return repr(value) if isinstance(value, float) else value


def _generate(chain, with_rotation: bool, with_jacobian: bool, name: str) -> str:
    fixed, motions = chain.segments()
    fixed = [[[_snap(x) for x in row] for row in f] for f in fixed]
    n = chain.n
    w = _Writer()
    q_names = [f"q{i}" for i in range(n)]
    header = [f"def {name}(q, cos=cos, sin=sin):", f"    {', '.join(q_names)}, = q"]

    # current frame: R[i][j] and p[i], identity to start
    R: list[list[Value]] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    p: list[Value] = [0.0, 0.0, 0.0]
    axes, origins = [], []

    def apply_fixed(f) -> None:
        nonlocal R, p
        new_r = [[w.combine([(R[i][k], f[k][j]) for k in range(3)]) for j in range(3)] for i in range(3)]
        new_p = [w.combine([(R[i][k], f[k][3]) for k in range(3)] + [(p[i], 1.0)]) for i in range(3)]
        R, p = new_r, new_p

    for i in range(n):
        apply_fixed(fixed[i])
        motion = motions[i]
        column = 0 if motion == MOTION_TRANS_X else 2
        axes.append([R[r][column] for r in range(3)])
        origins.append(list(p))
        if motion == MOTION_ROT_Z:
            w.lines += [f"    c{i} = cos(q{i})", f"    s{i} = sin(q{i})"]
            c, s = f"c{i}", f"s{i}"
            x = [w.combine([(c, R[r][0]), (s, R[r][1])]) for r in range(3)]
            y = [w.combine([(c, R[r][1]), (f"-{s}", R[r][0])]) for r in range(3)]
            for r in range(3):
                R[r][0], R[r][1] = x[r], y[r]
        else:
            p = [w.combine([(q_names[i], R[r][column]), (p[r], 1.0)]) for r in range(3)]
    apply_fixed(fixed[n])
    pe = [_text(v) for v in p]
    outputs = list(pe)
    if with_rotation:
        outputs += [_text(R[i][j]) for i in range(3) for j in range(3)]
    if with_jacobian:
        rows_v = [[], [], []]
        rows_w = [[], [], []]
        for i in range(n):
            z, o = axes[i], origins[i]
            if chain.prismatic[i]:
                for r in range(3):
                    rows_v[r].append(_text(z[r]))
                    rows_w[r].append("0.0")
                continue
            diff = [w.combine([(p[r], 1.0), (o[r], -1.0)]) for r in range(3)]
            # v = z x diff
            cross = [
                w.combine([(z[1], diff[2]), (_neg(z[2]), diff[1])]),
                w.combine([(z[2], diff[0]), (_neg(z[0]), diff[2])]),
                w.combine([(z[0], diff[1]), (_neg(z[1]), diff[0])]),
            ]
            for r in range(3):
                rows_v[r].append(_text(cross[r]))
                rows_w[r].append(_text(z[r]))
        if with_rotation:  # one flat list: numpy reshapes it faster than nested lists
            outputs.append("[" + ", ".join(sum(rows_v + rows_w, [])) + "]")
        else:
            outputs += ["[" + ", ".join(row) + "]" for row in rows_v]
    result = f"    return ({', '.join(outputs)})"
    return "\n".join(header + _eliminate_dead(w.lines, result) + [result, ""])


def _neg(value: Value) -> Value:
    """-value for a constant; a negated local is expressed as a '-name' atom."""
    if isinstance(value, float):
        return -value
    return value[1:] if value.startswith("-") else f"-{value}"


def build_kernel(chain) -> Kernel:
    """Generate, compile and return the kernel functions of ``chain``."""
    variants = {
        "position": (False, False),
        "pose": (True, False),
        "position_jacobian": (False, True),
        "pose_jacobian": (True, True),
    }
    source = "\n".join(_generate(chain, rot, jac, name) for name, (rot, jac) in variants.items())
    namespace = {"cos": math.cos, "sin": math.sin}
    exec(compile(source, f"<kernel {chain.name}>", "exec"), namespace)  # the source is generated above
    return Kernel(source=source, **{name: namespace[name] for name in variants})
