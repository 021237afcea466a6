"""Serial-arm kinematics: plain Python + numpy, no ROS (differential drive: amr_util.diff_drive).

Arms: a ``Chain`` is data (DH or planar rows, limits, couplings), loaded with
``load_chain_set`` from ROS 2 parameters or ``load_ull_json``; ``chain.fk`` and
``chain.jacobian`` are its kinematics; solvers are looked up by name with
``get_solver`` ("ccd", "dls", "pinv", "analytic") and share one ``solve``
signature returning an ``IKResult``.  Every error is a ``KinematicsError``
(a ValueError).
"""

from .chain import Chain, Coupling, FKResult
from .config import ChainConfig, load_chain_set
from .errors import ChainConfigError, InvalidRequestError, KinematicsError, SolverNotApplicableError, UnknownSolverError
from .solvers import SOLVERS, IKResult, applicable_solvers, follow_path, get_solver, solve
from .ull_json import load_ull_json

__all__ = [
    "SOLVERS",
    "Chain",
    "ChainConfig",
    "ChainConfigError",
    "Coupling",
    "FKResult",
    "IKResult",
    "InvalidRequestError",
    "KinematicsError",
    "SolverNotApplicableError",
    "UnknownSolverError",
    "applicable_solvers",
    "follow_path",
    "get_solver",
    "load_chain_set",
    "load_ull_json",
    "solve",
]
