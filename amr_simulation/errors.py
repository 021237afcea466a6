"""Exceptions of the simulator library: all ValueErrors, so callers may catch one type (a malformed world
is amr_maps.world.WorldError, a bad parameter amr_util.parameter_spec.ConfigError: ValueErrors too)."""


class SimulationError(ValueError):
    """A request the simulator cannot honour (bad command, pose inside a wall, ...)."""
