"""The environment of a child process started from this venv's Python (a node, a tool, a test)."""

from __future__ import annotations

import os

BOOTSTRAP_VARIABLES = ("LD_LIBRARY_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE")
"""Set by the ROS wheels for this interpreter; a child must set up its own library path."""


def child_environment(**extra: str) -> dict[str, str]:
    """This environment without the wheels' bootstrap markers, plus `extra`."""
    env = {k: v for k, v in os.environ.items() if k not in BOOTSTRAP_VARIABLES}
    env.update(extra)
    return env
