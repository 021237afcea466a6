"""amr_mapping's error: a map, a path or an input the mapping code cannot use, with a message naming it."""

from __future__ import annotations


class MappingError(ValueError):
    """A mapping problem (a path that cannot be written, a malformed scan, ...); the message names what and where."""
