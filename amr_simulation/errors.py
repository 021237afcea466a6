"""Exceptions of the simulator library: all ValueErrors, so callers may catch one type (a malformed world
is amr_maps.world.WorldError, also a ValueError)."""


class SimulationError(ValueError):
    """A request the simulator cannot honour (bad command, pose inside a wall, ...)."""


class ConfigError(SimulationError):
    """A parameter that is missing, of the wrong type or out of range; the message names it."""
