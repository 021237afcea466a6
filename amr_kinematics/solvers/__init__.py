"""IK solvers by name: one interface (``Solver.solve``), one registry.

from amr_kinematics.solvers import get_solver
result = get_solver("dls").solve(chain, target, seed=q, with_orientation=True)
"""

from __future__ import annotations

from ..errors import SolverNotApplicableError, UnknownSolverError
from .analytic import AnalyticSolver, follow_path, two_link_branches
from .base import IKResult, IterationRecord, Solver
from .ccd import CCDSolver
from .dls import DLSSolver
from .pinv import PinvSolver
from .starts import SpreadStarts, latin_hypercube

SOLVERS: dict[str, Solver] = {s.name: s for s in (CCDSolver(), DLSSolver(), PinvSolver(), AnalyticSolver())}


def get_solver(name: str) -> Solver:
    """The registered solver, or UnknownSolverError listing the known names."""
    try:
        return SOLVERS[name]
    except (KeyError, TypeError):
        raise UnknownSolverError(f"unknown solver {name!r}; known: {sorted(SOLVERS)}") from None


def applicable_solvers(chain, with_orientation: bool = False) -> list[str]:
    """Names of the solvers that accept this chain (and orientation request)."""
    names = []
    for name, solver in SOLVERS.items():
        try:
            solver.check(chain, with_orientation)
        except SolverNotApplicableError:
            continue
        names.append(name)
    return names


def solve(chain, target, solver: str = "dls", **kwargs) -> IKResult:
    """Shortcut: ``get_solver(solver).solve(chain, target, **kwargs)``."""
    return get_solver(solver).solve(chain, target, **kwargs)


__all__ = [
    "SOLVERS",
    "AnalyticSolver",
    "CCDSolver",
    "DLSSolver",
    "IKResult",
    "IterationRecord",
    "PinvSolver",
    "Solver",
    "SpreadStarts",
    "applicable_solvers",
    "follow_path",
    "get_solver",
    "latin_hypercube",
    "solve",
    "two_link_branches",
]
