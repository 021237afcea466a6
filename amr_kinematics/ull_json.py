"""Import of the ULL report's JSON joint list (seed 000, figures 3.4 and 3.5).

Each joint is ``{"type": "rotacion" | "prismatica", "th": ..., "a": ...,
"limit_inf": ..., "limit_sup": ...}``, from the base to the tip; nested lists
are flattened in order.  The report's planar joint: a revolute joint's value is
its angle th (link length a fixed), a prismatic joint's value is its length a
(angle th fixed).  Lengths are multiplied by ``length_scale`` (the report's
units are unnamed; 0.01 reads them as centimetres).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .chain import PLANAR, PRISMATIC, REVOLUTE, Chain
from .errors import ChainConfigError

_TYPES = {"rotacion": REVOLUTE, "prismatica": PRISMATIC}
_KEYS = ("type", "th", "a", "limit_inf", "limit_sup")


def _flatten(items, out: list) -> list:
    for item in items:
        if isinstance(item, list):
            _flatten(item, out)
        else:
            out.append(item)
    return out


def load_ull_json(source, *, name: str = "ull", length_scale: float = 1.0) -> tuple[Chain, np.ndarray]:
    """(planar chain, initial joint vector) from a path, a JSON string or the parsed list."""
    if isinstance(source, Path) or (isinstance(source, str) and not source.lstrip().startswith("[")):
        source = Path(source).read_text(encoding="utf-8")
    if isinstance(source, str):
        try:
            source = json.loads(source)
        except json.JSONDecodeError as exc:
            raise ChainConfigError(name, None, f"not valid JSON: {exc}") from exc
    if not isinstance(source, list):
        raise ChainConfigError(name, None, "the JSON must be a list of joints")
    joints = _flatten(source, [])
    if not joints:
        raise ChainConfigError(name, None, "the JSON has no joints")
    if not (isinstance(length_scale, (int, float)) and math.isfinite(length_scale) and length_scale > 0):
        raise ChainConfigError(name, "length_scale", f"must be a positive number, got {length_scale!r}")
    types, theta, a, lower, upper, q0 = [], [], [], [], [], []
    for index, joint in enumerate(joints, start=1):
        where = f"joint {index}"
        if not isinstance(joint, dict):
            raise ChainConfigError(name, where, f"must be an object, got {joint!r}")
        missing = [k for k in _KEYS if k not in joint]
        if missing:
            raise ChainConfigError(name, f"{where}.{missing[0]}", "is missing")
        if joint["type"] not in _TYPES:
            raise ChainConfigError(
                name, f"{where}.type", f"unknown type {joint['type']!r}, expected 'rotacion' or 'prismatica'"
            )
        for key in _KEYS[1:]:
            value = joint[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ChainConfigError(name, f"{where}.{key}", f"must be a finite number, got {value!r}")
        joint_type = _TYPES[joint["type"]]
        types.append(joint_type)
        if joint_type == REVOLUTE:
            theta.append(0.0)
            a.append(float(joint["a"]) * length_scale)
            lower.append(float(joint["limit_inf"]))
            upper.append(float(joint["limit_sup"]))
            q0.append(float(joint["th"]))
        else:
            theta.append(float(joint["th"]))
            a.append(0.0)
            lower.append(float(joint["limit_inf"]) * length_scale)
            upper.append(float(joint["limit_sup"]) * length_scale)
            q0.append(float(joint["a"]) * length_scale)
    chain = Chain(
        name, PLANAR, [f"joint{i}" for i in range(1, len(types) + 1)], types, theta=theta, a=a, lower=lower, upper=upper
    )
    return chain, np.array(q0)
