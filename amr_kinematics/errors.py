"""Exception types of the kinematics library.

Every error is a ``KinematicsError`` (a ``ValueError``), so a caller such as
the IK service node can catch the one base class and turn it into a reply.
"""

from __future__ import annotations

from amr_util.parameter_spec import ConfigError


class KinematicsError(ValueError):
    """Base class: bad input to the kinematics library."""


class ChainConfigError(KinematicsError, ConfigError):
    """A chain description (parameters, JSON) is malformed; names chain and key. The suite's
    ConfigError (amr_util.parameter_spec) too, as every bad parameter is."""

    def __init__(self, chain: str | None, key: str | None, problem: str) -> None:
        self.chain = chain
        self.key = key
        self.problem = problem
        where = []
        if chain is not None:
            where.append(f"chain '{chain}'")
        if key is not None:
            where.append(f"key '{key}'")
        prefix = (", ".join(where) + ": ") if where else ""
        super().__init__(prefix + problem)


class InvalidRequestError(KinematicsError):
    """A solve or FK request is malformed: wrong length, NaN/inf, bad option."""


class SolverNotApplicableError(KinematicsError):
    """The solver cannot handle this chain or this request on this chain."""


class UnknownSolverError(SolverNotApplicableError):
    """No solver is registered under the requested name."""
