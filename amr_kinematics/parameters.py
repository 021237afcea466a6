"""The IK service's ROS parameters: one spec per key given, no ROS.

A chain's parameters are `<chain>.<key>`, each key stated once in amr_kinematics.config.CHAIN_KEYS
(kind, meaning, limits, live or structural); which chains exist is only known from what the node is
given, so the specs are made from those names. Geometry (the chain list, conventions, DH tables or
URDF, limits, couplings, home) is structural: refused while the node is configured. Solve defaults
(solver, tolerances, iterations, timeout, solver options) and the service-wide caps are live: the
chain set is validated again and takes effect at the next request.
"""

from __future__ import annotations

import dataclasses

from amr_kinematics.config import CHAIN_KEYS
from amr_util.parameter_spec import ParameterSpec

SERVICE_PARAMETERS = (
    ParameterSpec(
        "max_timeout",
        1.0,
        "s; a request's (or a chain's default) timeout above this is capped to it",
        minimum=1e-4,
        maximum=600.0,
        live=True,
    ),
    ParameterSpec(
        "max_iterations_limit",
        100_000,
        "a request's (or a chain's default) max_iterations above this is capped to it",
        minimum=1,
        maximum=100_000_000,
        live=True,
    ),
)
CHAINS = ParameterSpec("chains", [""], "names of the chains served", kind="str_array")


def chain_specs(given: dict) -> tuple[ParameterSpec, ...]:
    """Specs for `chains` and every `<chain>.<key>` in `given` (name: value) whose key a chain may have.

    Chains described but not listed are declared too (a file may describe more arms than are
    served; `chains` picks). Unknown keys get no spec: the node reports them as unknown. A node
    widens integers given for floats (the chain loader, reading a file itself, asks for `1.0`).
    """
    chains = given.get("chains", [])
    chains = [name for name in chains if isinstance(name, str)] if isinstance(chains, (list, tuple)) else []
    specs = [*SERVICE_PARAMETERS, dataclasses.replace(CHAINS, default=list(chains) or [""])]
    for name in sorted(given):
        chain, _, key = name.partition(".")
        if key in CHAIN_KEYS:
            key_spec = CHAIN_KEYS[key]
            spec = dataclasses.replace(
                key_spec,
                name=name,
                description=f"{chain}: {key_spec.description}",
                integers_as_floats=True,
                nonempty=False,
                default=_neutral(key_spec),
            )
            try:  # a valid given value is the default; a bad one is reported by the node, by name
                spec = dataclasses.replace(spec, default=spec.coerce(given[name]))
            except ValueError:
                pass
            specs.append(spec)
    return tuple(specs)


def _neutral(spec: ParameterSpec):
    """A placeholder of the right type (and in range) for a key whose given value is bad."""
    if spec.kind.endswith("_array"):
        return []
    low = spec.minimum if spec.minimum is not None else 0
    if spec.exclusive_minimum:
        low = low + 1 if spec.kind == "int" else spec.maximum
    return {"str": "", "bool": False, "int": int(low), "float": float(low)}[spec.kind]
