"""The one error a planner raises: a request it cannot serve, with the reason named."""

from __future__ import annotations

from enum import StrEnum


class Reason(StrEnum):
    """Why no path was returned; the value is a short tag for status messages."""

    INVALID = "invalid request"
    OUTSIDE_MAP = "outside the map"
    START_BLOCKED = "start inside an obstacle"
    GOAL_BLOCKED = "goal inside an obstacle"
    UNREACHABLE = "goal unreachable"


class PlanningError(ValueError):
    """No path: the message says what is wrong; `reason` classifies it, `endpoint` says which end of the request
    ("start", "goal" or "" for neither) was refused. A planner never returns half a path."""

    def __init__(self, reason: Reason, message: str, endpoint: str = "") -> None:
        super().__init__(f"{reason.value}: {message}")
        self.reason = reason
        self.endpoint = endpoint

    @property
    def goal_refused(self) -> bool:
        """The goal itself cannot be planned to (not finite, off the map, inside an obstacle): whatever the
        start, no plan to it will succeed on this map."""
        return self.endpoint == "goal"
