"""Exceptions of the simulator library: all ValueErrors, so callers may catch one type (a bad parameter
raises amr_util.parameter_spec.ConfigError, a ValueError too)."""


class SimulationError(ValueError):
    """A request the simulator cannot honour (bad command, pose inside a wall, ...)."""


class WorldError(SimulationError):
    """A world description that is malformed; the message names the file and the key."""

