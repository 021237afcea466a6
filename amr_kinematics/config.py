"""Chains and their solve defaults from ROS 2 parameters (all-or-nothing).

ROS parameters have no list of maps, so a chain is parallel arrays under its
name.  ``load_chain_set`` takes the YAML as loaded (``{ik_service: {ros__parameters:
{...}}}``, or the inner dict, nested or with dotted keys) or the flat dict rclpy
gives (``{"chains": [...], "arm5.types": [...]}``), checks every chain and
returns them all, or raises one ``ChainConfigError`` naming chain and key.

Keys per chain (SI units, angles in radians; lists of floats written as floats,
``1.0`` not ``1``: rclpy reads ``[1, 2]`` as integers and refuses ``[1, 2.5]``):

required   convention ("standard_dh" | "modified_dh" | "planar"), joint_names,
           types ("revolute" | "prismatic" each), theta, a, lower, upper,
           and for DH chains d, alpha
or, instead of the DH keys and couplings, a URDF (``amr_kinematics.urdf``):
           urdf (a file path, package://<pkg>/<path> through the ament index, or the
           XML itself), base_link, tip_link; joints, limits and mimics come from it
optional   base_xyz_rpy, tool_xyz_rpy ([x, y, z, roll, pitch, yaw]),
           coupled_joint (names), coupling_offset (one per coupled joint),
           coupling_coefficients (n per coupled joint, concatenated):
               q[coupled_joint[k]] = coupling_offset[k] + sum_i c[k*n + i] q[i]
           home (default: zeros clamped into the limits)
defaults   solver, tolerance, orientation_tolerance, max_iterations, timeout,
           and solver options damping, adaptive_damping, angular_weight,
           coupling_update, axis_tolerance, restarts, samples, gain
Keys of chains not listed in ``chains`` are ignored; unknown keys of listed
chains are errors (a typo must not fall back to a default silently).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from amr_util.parameter_file import dotted
from amr_util.parameter_spec import ConfigError, ParameterSpec

from .chain import CONVENTIONS, JOINT_TYPES, PLANAR, Chain, Coupling
from .errors import ChainConfigError, KinematicsError, SolverNotApplicableError
from .solvers import SOLVERS, IKResult, get_solver
from .solvers.base import DEFAULT_MAX_ITERATIONS, DEFAULT_TIMEOUT, DEFAULT_TOLERANCE, MAX_TIMEOUT, MAX_TOLERANCE
from .solvers.task import parse_task
from .transforms import xyz_rpy_matrix
from .urdf import urdf_chain

PARTIAL_POSE_WEIGHTS = (1.0, 1.0, 1.0, 0.0, 0.0, 1.0)
"""Position and yaw: the partial pose the warm-up solves once."""

NODE_NAME = "ik_service"


def _key(kind: str, description: str, live: bool = False, default=None, **limits) -> ParameterSpec:
    """One chain key: its kind, meaning, default (what a chain without the key gets) and limits (named
    `<chain>.<key>` where used)."""
    neutral = {"str": "", "bool": False, "int": 1, "float": 0.0}
    if default is None:
        default = [] if kind.endswith("_array") else neutral[kind]
    return ParameterSpec(
        "",
        default,
        description,
        kind=kind,
        live=live,
        nonempty=kind.startswith("str") or kind.endswith("_array"),
        integers_as_floats=False,
        **limits,
    )


CHAIN_KEYS: dict[str, ParameterSpec] = {
    # geometry (structural: refused while the node is configured)
    "convention": _key("str", "standard_dh | modified_dh | planar (required without urdf)"),
    "joint_names": _key("str_array", "one name per joint (required without urdf)"),
    "types": _key("str_array", "revolute | prismatic, one per joint (required without urdf)"),
    "theta": _key("float_array", "rad, DH joint angle offsets (required without urdf)"),
    "a": _key("float_array", "m, DH link lengths (required without urdf)"),
    "d": _key("float_array", "m, DH link offsets (required for a DH chain)"),
    "alpha": _key("float_array", "rad, DH link twists (required for a DH chain)"),
    "lower": _key("float_array", "joint lower limits, rad or m (required without urdf)"),
    "upper": _key("float_array", "joint upper limits, rad or m (required without urdf)"),
    "base_xyz_rpy": _key("float_array", "[x, y, z, roll, pitch, yaw] of the chain's base in the world"),
    "tool_xyz_rpy": _key("float_array", "[x, y, z, roll, pitch, yaw] of the tool in the last link"),
    "coupled_joint": _key("str_array", "joints driven by others: q = offset + sum c_i q_i"),
    "coupling_offset": _key("float_array", "one offset per coupled joint"),
    "coupling_coefficients": _key("float_array", "n coefficients per coupled joint"),
    "home": _key("float_array", "the seed when a request gives none ([]: zeros clamped into the limits)"),
    "urdf": _key("str", "a URDF instead of a DH table: file path, package://<pkg>/<path> or the XML itself"),
    "base_link": _key("str", "URDF link the chain starts at"),
    "tip_link": _key("str", "URDF link the chain ends at (the tool)"),
    # solve defaults (live: the chain set is validated again and used from the next request)
    "solver": _key("str", "default solver: ccd | dls | pinv | analytic", live=True, default="dls"),
    "tolerance": _key(
        "float",
        "m (and rad), default position tolerance",
        live=True,
        default=DEFAULT_TOLERANCE,
        minimum=0.0,
        exclusive_minimum=True,
        maximum=MAX_TOLERANCE,
    ),
    "orientation_tolerance": _key(
        "float",
        "rad, default orientation tolerance (unset: the tolerance)",
        live=True,
        default=DEFAULT_TOLERANCE,
        minimum=0.0,
        exclusive_minimum=True,
        maximum=math.pi,
    ),
    "max_iterations": _key(
        "int",
        "default iteration cap of one descent",
        live=True,
        default=DEFAULT_MAX_ITERATIONS,
        minimum=0,
        exclusive_minimum=True,
        maximum=10_000_000,
    ),
    "timeout": _key(
        "float",
        "s, default solve budget",
        live=True,
        default=DEFAULT_TIMEOUT,
        minimum=0.0,
        exclusive_minimum=True,
        maximum=MAX_TIMEOUT,
    ),
    "damping": _key("float", "DLS damping factor", live=True, minimum=0.0, maximum=100.0),
    "adaptive_damping": _key("float", "DLS adaptive damping", live=True),
    "angular_weight": _key("float", "weight of orientation error against position error", live=True),
    "coupling_update": _key("str", "coupling handling", live=True),
    "axis_tolerance": _key("float_array", "per-axis tolerances", live=True),
    "restarts": _key("bool", "random restarts inside the budget", live=True),
    "samples": _key("int", "pinv multi-start samples", live=True, minimum=0, exclusive_minimum=True, maximum=100_000),
    "gain": _key("float", "step gain", live=True, minimum=0.0, maximum=10.0),
}
"""Every key a chain may have, stated once: the loader checks values with these, the node declares them
(`<chain>.<key>`) and the docs list them."""

_REQUIRED = ("convention", "joint_names", "types", "theta", "a", "lower", "upper")
_URDF_KEYS = ("urdf", "base_link", "tip_link")
_FROM_URDF = (
    "convention",
    "joint_names",
    "types",
    "theta",
    "a",
    "d",
    "alpha",
    "lower",
    "upper",
    "coupled_joint",
    "coupling_offset",
    "coupling_coefficients",
)
_SOLVER_OPTIONS = (
    "damping",
    "adaptive_damping",
    "angular_weight",
    "coupling_update",
    "axis_tolerance",
    "restarts",
    "samples",
    "gain",
)


@dataclass(frozen=True)
class ChainConfig:
    """A chain with its home configuration and solve defaults.

    ``solve`` is what a service calls: empty/zero arguments take the defaults,
    a missing seed takes ``home``; solver options apply to the solvers that
    have them.
    """

    chain: Chain
    home: np.ndarray
    solver: str = "dls"
    tolerance: float = DEFAULT_TOLERANCE
    orientation_tolerance: float | None = None
    max_iterations: int = DEFAULT_MAX_ITERATIONS
    timeout: float = DEFAULT_TIMEOUT
    solver_options: Mapping[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        return self.chain.name

    def options_for(self, solver: str) -> dict:
        """The configured options the named solver accepts."""
        accepted = get_solver(solver).options
        return {k: v for k, v in self.solver_options.items() if k in accepted}

    def solve(
        self,
        target,
        *,
        solver: str = "",
        seed=None,
        with_orientation: bool = False,
        tolerance: float = 0.0,
        max_iterations: int = 0,
        timeout: float = 0.0,
        record_history: bool = False,
        task=None,
    ) -> IKResult:
        """IK with this chain's defaults for every empty/zero argument.

        An explicit ``tolerance`` replaces both the default tolerance and any
        per-axis ``axis_tolerance`` of the config.
        """
        if "_warmed" not in self.__dict__:  # the first solve's budget is not spent loading compiled code
            self.warm_up()
        name = solver or self.solver
        options = self.options_for(name)
        if tolerance:
            options.pop("axis_tolerance", None)
        return get_solver(name).solve(
            self.chain,
            target,
            seed=self.home if seed is None or len(seed) == 0 else seed,
            with_orientation=with_orientation,
            tolerance=tolerance or self.tolerance,
            orientation_tolerance=None if tolerance else self.orientation_tolerance,
            max_iterations=max_iterations or self.max_iterations,
            timeout=timeout or self.timeout,
            record_history=record_history,
            task=task,
            **options,
        )

    def warm_up(self) -> None:
        """Run every code path a request may take once (each applicable solver, position and,
        when the chain can orient, full pose): the first request on a fresh process paid
        ~35 ms of first-call costs (lazy imports, caches) and overran its 5 ms budget.  An
        unreachable target then runs the restart paths (numba loads each compiled function from
        its cache at its first call: ~0.3 s).  The first ``solve`` of a config calls it, so
        library users get the same; a node calls it at configure."""
        from .solvers import applicable_solvers

        object.__setattr__(self, "_warmed", True)  # frozen, but this is a cache, not a field; before the solves below

        chain = self.chain
        goal = chain.fk(self.home).tool
        start = chain.apply_coupling(chain.clamp(self.home + 0.1))
        for with_orientation in (False, True) if chain.can_orient else (False,):
            target = goal if with_orientation else goal[: 2 if chain.planar else 3, 3]
            for name in applicable_solvers(chain, with_orientation):
                self.solve(target, solver=name, seed=start, with_orientation=with_orientation, timeout=0.05)
        far = goal[: 2 if chain.planar else 3, 3] + 1e3
        for name in applicable_solvers(chain, False):
            self.solve(far, solver=name, seed=start, timeout=0.002)
        if not chain.planar:  # a weighted (partial-pose) request compiles kernels of its own on a cold cache
            task = parse_task(PARTIAL_POSE_WEIGHTS)
            for name in applicable_solvers(chain, False):
                try:  # with the config's tolerances, and with an explicit one (no per-axis tolerance)
                    self.solve(goal, solver=name, seed=start, task=task, timeout=0.05)
                    self.solve(goal, solver=name, seed=start, task=task, timeout=0.05, tolerance=1e-6)
                except SolverNotApplicableError:
                    pass


def flatten_parameters(params: Mapping) -> dict:
    """Dotted-key dict from any of the accepted shapes (see module docstring)."""
    if not isinstance(params, Mapping):
        raise ChainConfigError(None, None, f"parameters must be a mapping, got {type(params).__name__}")
    if "ros__parameters" in params:
        params = params["ros__parameters"]
    elif len(params) == 1:
        (only,) = params.values()
        if isinstance(only, Mapping) and "ros__parameters" in only:
            params = only["ros__parameters"]
    return dotted(params)


def load_chain_set(params: Mapping) -> dict[str, ChainConfig]:
    """Every chain listed in ``chains``, validated; ChainConfigError otherwise."""
    flat = flatten_parameters(params)
    names = flat.get("chains")
    if not isinstance(names, (list, tuple)) or not names:
        raise ChainConfigError(None, "chains", "must be a non-empty list of chain names")
    for name in names:
        if not isinstance(name, str) or not name or "." in name or name != name.strip():
            raise ChainConfigError(None, "chains", f"chain names must be non-empty strings without dots, got {name!r}")
    if len(set(names)) != len(names):
        raise ChainConfigError(None, "chains", "chain names must be unique")
    configs = {}
    for name in names:
        prefix = name + "."
        keys = {k[len(prefix) :]: v for k, v in flat.items() if k.startswith(prefix)}
        configs[name] = _chain_config(name, keys)
    return configs


def _typed(name: str, key: str, value):
    """The value checked against its key's spec; ChainConfigError naming chain and key."""
    full = f"{name}.{key}"
    if key in ("types", "joint_names") and (value is None or value == []):  # rclpy reads `[]` as unset (None)
        raise ChainConfigError(name, full, "is empty: a chain needs at least one joint")
    try:
        return dataclasses.replace(CHAIN_KEYS[key], name=full).coerce(value)
    except ConfigError as error:
        raise ChainConfigError(name, full, str(error).removeprefix(f"{full}: ")) from None


def _chain_config(name: str, raw: dict) -> ChainConfig:
    unknown = sorted(set(raw) - set(CHAIN_KEYS))
    if unknown:
        raise ChainConfigError(name, f"{name}.{unknown[0]}", f"unknown key; known keys: {sorted(CHAIN_KEYS)}")
    first = ("types", "joint_names")  # an empty chain is named as such, not by its first empty list
    ordered = [key for key in first if key in raw] + [key for key in raw if key not in first]
    values = {key: _typed(name, key, raw[key]) for key in ordered}
    if any(key in values for key in _URDF_KEYS):
        chain = _urdf_chain(name, values)
    else:
        chain = _dh_chain(name, values)
    n = chain.n
    home = chain.apply_coupling(chain.clamp(np.zeros(n)))
    if "home" in values:
        home = np.array(values["home"])
        if home.size != n:
            raise ChainConfigError(name, f"{name}.home", f"has {home.size} values, the chain has {n} joints")
        if not chain.within_limits(home):
            raise ChainConfigError(name, f"{name}.home", f"{home.tolist()} is outside the joint limits")
    home.setflags(write=False)
    config = ChainConfig(
        chain=chain,
        home=home,
        solver=values.get("solver", CHAIN_KEYS["solver"].default),
        tolerance=values.get("tolerance", CHAIN_KEYS["tolerance"].default),
        orientation_tolerance=values.get("orientation_tolerance"),
        max_iterations=values.get("max_iterations", CHAIN_KEYS["max_iterations"].default),
        timeout=values.get("timeout", CHAIN_KEYS["timeout"].default),
        solver_options={k: values[k] for k in _SOLVER_OPTIONS if k in values},
    )
    _check_defaults(name, config)
    return config


def _dh_chain(name: str, values: dict) -> Chain:
    """A chain from a DH (or planar) table."""
    convention = values.get("convention")
    required = _REQUIRED + (() if convention == PLANAR else ("d", "alpha"))
    for key in required:
        if key not in values:
            raise ChainConfigError(name, f"{name}.{key}", "is required")
    if convention not in CONVENTIONS:
        raise ChainConfigError(
            name, f"{name}.convention", f"unknown convention {convention!r}, expected one of {CONVENTIONS}"
        )
    for joint_type in values["types"]:
        if joint_type not in JOINT_TYPES:
            raise ChainConfigError(
                name, f"{name}.types", f"unknown joint type {joint_type!r}, expected 'revolute' or 'prismatic'"
            )
    n = len(values["types"])
    base, tool = _base_and_tool(name, values)
    couplings = _couplings(name, values, n)
    try:
        return Chain(
            name,
            convention,
            values["joint_names"],
            values["types"],
            theta=values["theta"],
            a=values["a"],
            d=values.get("d"),
            alpha=values.get("alpha"),
            lower=values["lower"],
            upper=values["upper"],
            base=base,
            tool=tool,
            couplings=couplings,
        )
    except ChainConfigError as exc:
        key = {"base": "base_xyz_rpy", "tool": "tool_xyz_rpy"}.get(exc.key, exc.key)
        raise ChainConfigError(name, f"{name}.{key}", exc.problem) from None


def _base_and_tool(name: str, values: dict):
    """The optional base and tool transforms (4x4 or None)."""
    for key in ("base_xyz_rpy", "tool_xyz_rpy"):
        if key in values and len(values[key]) != 6:
            raise ChainConfigError(
                name, f"{name}.{key}", f"needs 6 values [x, y, z, roll, pitch, yaw], got {len(values[key])}"
            )
    return tuple(xyz_rpy_matrix(values[key]) if key in values else None for key in ("base_xyz_rpy", "tool_xyz_rpy"))


def _urdf_chain(name: str, values: dict) -> Chain:
    """A chain named by urdf, base_link and tip_link (joints, limits, mimics from the URDF)."""
    for key in _URDF_KEYS:
        if key not in values:
            raise ChainConfigError(name, f"{name}.{key}", "is required with a urdf chain (urdf, base_link, tip_link)")
    for key in _FROM_URDF:
        if key in values:
            raise ChainConfigError(name, f"{name}.{key}", "comes from the URDF: remove it (or remove urdf)")
    base, tool = _base_and_tool(name, values)
    try:
        return urdf_chain(name, values["urdf"], values["base_link"], values["tip_link"], base=base, tool=tool)
    except ChainConfigError as exc:
        raise ChainConfigError(name, f"{name}.{exc.key}", exc.problem) from None


def _couplings(name: str, values: dict, n: int) -> list[Coupling]:
    keys = ("coupled_joint", "coupling_offset", "coupling_coefficients")
    present = [k for k in keys if k in values]
    if not present:
        return []
    if len(present) != 3:
        missing = next(k for k in keys if k not in values)
        raise ChainConfigError(
            name, f"{name}.{missing}", "coupling needs coupled_joint, coupling_offset and coupling_coefficients"
        )
    joints, offsets, coefficients = (values[k] for k in keys)
    if len(offsets) != len(joints):
        raise ChainConfigError(
            name, f"{name}.coupling_offset", f"needs one offset per coupled joint ({len(joints)}), got {len(offsets)}"
        )
    if len(coefficients) != n * len(joints):
        raise ChainConfigError(
            name,
            f"{name}.coupling_coefficients",
            f"needs {n} coefficients per coupled joint ({n * len(joints)} in all), got {len(coefficients)}",
        )
    names = values["joint_names"]
    out = []
    for k, joint in enumerate(joints):
        if joint not in names:
            raise ChainConfigError(name, f"{name}.coupled_joint", f"{joint!r} is not one of the joint names {names}")
        out.append(Coupling(names.index(joint), offsets[k], np.array(coefficients[k * n : (k + 1) * n])))
    return out


def _check_defaults(name: str, config: ChainConfig) -> None:
    """The defaults must give a working solve: known, applicable solver, sane options."""
    if config.solver not in SOLVERS:
        raise ChainConfigError(name, f"{name}.solver", f"unknown solver {config.solver!r}; known: {sorted(SOLVERS)}")
    try:
        get_solver(config.solver).check(config.chain)
    except KinematicsError as exc:
        raise ChainConfigError(name, f"{name}.solver", str(exc)) from None
    for key, value in config.solver_options.items():
        for solver in SOLVERS.values():
            if key in solver.options:
                try:
                    solver._configured({key: value}, config.chain.planar)
                except KinematicsError as exc:
                    raise ChainConfigError(name, f"{name}.{key}", str(exc)) from None
