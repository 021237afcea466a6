"""The IK service's ROS parameters: one spec per key given, no ROS.

A chain's parameters are `<chain>.<key>` (keys in amr_kinematics.config); which chains exist is
only known from what the node is given, so the specs are made from those names. Geometry (the
chain list, conventions, DH tables or URDF, limits, couplings, home) is structural: refused while the
node is configured. Solve defaults (solver, tolerances, iterations, timeout, solver options) and
the service-wide caps are live: the chain set is validated again and takes effect at the next
request.
"""

from __future__ import annotations

import dataclasses

from amr_kinematics.config import _BOOL, _FLOAT, _FLOAT_LIST, _INT, _KNOWN, _STRING, _STRING_LIST
from amr_util.parameter_spec import ParameterSpec

CHAIN_KEYS = _KNOWN
"""Every key a chain may have."""
LIVE_KEYS = frozenset({"solver", "tolerance", "orientation_tolerance", "max_iterations", "timeout", "damping",
                       "adaptive_damping", "angular_weight", "coupling_update", "axis_tolerance", "restarts",
                       "samples", "gain"})
KEY_DOCS = {
    "convention": "standard_dh | modified_dh | planar",
    "joint_names": "one name per joint",
    "types": "revolute | prismatic, one per joint",
    "theta": "rad, DH joint angle offsets", "a": "m, DH link lengths", "d": "m, DH link offsets",
    "alpha": "rad, DH link twists", "lower": "joint lower limits (rad or m)", "upper": "joint upper limits (rad or m)",
    "base_xyz_rpy": "[x, y, z, roll, pitch, yaw] of the chain's base in the world",
    "tool_xyz_rpy": "[x, y, z, roll, pitch, yaw] of the tool in the last link",
    "coupled_joint": "joints driven by others: q = offset + sum c_i q_i",
    "coupling_offset": "one offset per coupled joint", "coupling_coefficients": "n coefficients per coupled joint",
    "home": "the seed when a request gives none",
    "urdf": "a URDF instead of a DH table: file path, package://<pkg>/<path> or the XML itself",
    "base_link": "URDF link the chain starts at", "tip_link": "URDF link the chain ends at (the tool)",
    "solver": "default solver: ccd | dls | pinv | analytic", "tolerance": "m (and rad), default position tolerance",
    "orientation_tolerance": "rad, default orientation tolerance", "max_iterations": "default iteration cap",
    "timeout": "s, default solve budget", "damping": "DLS damping factor", "adaptive_damping": "DLS adaptive damping",
    "angular_weight": "weight of orientation error against position error", "coupling_update": "coupling handling",
    "axis_tolerance": "per-axis tolerances", "restarts": "random restarts inside the budget",
    "samples": "pinv multi-start samples", "gain": "step gain",
}
RANGES = {"tolerance": (1e-12, 1.0), "orientation_tolerance": (1e-12, 3.14159), "max_iterations": (1, 10_000_000),
          "timeout": (1e-4, 60.0), "damping": (0.0, 100.0), "samples": (1, 100_000), "gain": (0.0, 10.0)}
SERVICE_PARAMETERS = (
    ParameterSpec("max_timeout", 1.0, "s; a request's (or a chain's default) timeout above this is capped to it",
                  minimum=1e-4, maximum=600.0, live=True),
    ParameterSpec("max_iterations_limit", 100_000,
                  "a request's (or a chain's default) max_iterations above this is capped to it",
                  minimum=1, maximum=100_000_000, live=True),
)


def _kind(key: str) -> str:
    for kinds, kind in ((_STRING, "str"), (_STRING_LIST, "str_array"), (_FLOAT, "float"),
                        (_FLOAT_LIST, "float_array"), (_INT, "int"), (_BOOL, "bool")):
        if key in kinds:
            return kind
    return ""


def chain_specs(given: dict) -> tuple[ParameterSpec, ...]:
    """Specs for `chains` and every `<chain>.<key>` in `given` (name: value) whose key a chain may have.

    Chains described but not listed are declared too (a file may describe more arms than are
    served; `chains` picks). Unknown keys get no spec: the node reports them as unknown.
    """
    chains = given.get("chains", [])
    chains = [name for name in chains if isinstance(name, str)] if isinstance(chains, (list, tuple)) else []
    specs = [*SERVICE_PARAMETERS, ParameterSpec("chains", list(chains) or [""], "names of the chains served",
                                                kind="str_array")]
    for name in sorted(given):
        chain, _, key = name.partition(".")
        kind = _kind(key)
        if key and kind:
            low, high = RANGES.get(key, (None, None))
            spec = ParameterSpec(name, _neutral(kind, low), f"{chain}: {KEY_DOCS.get(key, key)}", minimum=low,
                                 maximum=high, live=key in LIVE_KEYS, kind=kind)
            try:  # a valid given value is the default; a bad one is reported by the node, by name
                spec = dataclasses.replace(spec, default=spec.coerce(given[name]))
            except ValueError:
                pass
            specs.append(spec)
    return tuple(specs)


def _neutral(kind: str, minimum: float | None):
    """A placeholder of the right type (and in range) for a key whose given value is bad."""
    if kind.endswith("_array"):
        return []
    return {"str": "", "bool": False, "int": int(minimum or 0), "float": float(minimum or 0.0)}[kind]
