"""Exceptions of the simulator library: all ValueErrors, so callers may catch one type."""


class SimulationError(ValueError):
    """A request the simulator cannot honour (bad command, pose inside a wall, ...)."""


class WorldError(SimulationError):
    """A world description that is malformed; the message names the file and the key."""


class ConfigError(SimulationError):
    """A parameter that is missing, of the wrong type or out of range; the message names it."""
