"""What the page's buttons do beyond a call, and what the viewer says under them: no rclpy.

A reset restarts every localizer's global localization first (a reset is a kidnapping no localizer is told of), so
`Countdown` holds the simulators' reset until each localizer has answered or timed out. An answer is the service's
response, or the exception its future holds (amr_viewer.pending)."""

from __future__ import annotations

from collections.abc import Callable, Iterable

NO_SIMULATOR = "no simulator found (a node with ~/pause, ~/resume, ~/step, ~/reset)"
PAUSING = ("pause", "step", "resume")
"""Controls whose success says whether the simulator is paused (all but resume leave it paused)."""


class Countdown:
    """Calls `then` once, when every one of `names` is done (answered or given up on)."""

    def __init__(self, names: Iterable[str], then: Callable[[], None]) -> None:
        self.waiting = set(names)
        self._then = then

    def done(self, name: str) -> None:
        if not self.waiting:
            return
        self.waiting.discard(name)
        if not self.waiting:
            self._then()


def restart_note(localizers: Iterable[str]) -> str:
    """Said after a reset's answer when the localizers were restarted first."""
    return f"; global localization restarted on {', '.join(localizers)}"


def control_reply(simulator: str, service: str, answer, note: str = "") -> tuple[str, bool | None]:
    """A simulator's answer to ~/<service>: the line under the buttons (`note` after a success), and whether the
    simulator is now paused (None: not known from this answer)."""
    if isinstance(answer, Exception):
        return f"{simulator}/{service}: {answer}", None
    text = f"{simulator}: {answer.message}" + (note if answer.success else "")
    paused = service != "resume" if answer.success and service in PAUSING else None
    return text, paused


def set_result(answer):
    """The one SetParameters result of an answer, or None (an exception, or no result)."""
    return answer.results[0] if not isinstance(answer, Exception) and answer.results else None


def taken(answer) -> bool:
    """Whether a SetParameters answer took the value."""
    result = set_result(answer)
    return result is not None and result.successful


def simulator_parameter_reply(simulator: str, name: str, value, answer) -> str:
    """A simulator's answer to setting its parameter `name` (the pace)."""
    if taken(answer):
        return f"{simulator}: {name} = {value}"
    result = set_result(answer)
    return f"{simulator} refused {name} = {value}: {result.reason if result is not None else answer}"


def parameter_reply(node: str, name: str, value, text: str, answer) -> str:
    """A node's answer to setting its parameter `name` to `value` (`text`: the value as the panel shows it once
    taken): the line under the panel."""
    if taken(answer):
        return f"{node}: {name} = {text}"
    result = set_result(answer)
    reason = result.reason if result is not None else str(answer)
    return f"{node} refused {name} = {value!r}: {reason or '(no reason given)'}"
