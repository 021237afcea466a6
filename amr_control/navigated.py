"""What a controller node does when a navigator decides who drives (`navigated: true`), no control logic.

The navigator (amr_navigation) publishes one amr_interfaces/NavigatorStatus per observation, stamped
like the observation's /scan; the controller pairs it with its own inputs of that observation (by the
synchronizer, as one more input) and answers the observation only when the status names it
(`controller` == this node's name). So in lockstep exactly one command answers each observation, across
every hand-over, without any controller listening to /cmd_vel.

An observation the status did not give this node is held (its inputs, by stamp). If the navigator later
sends a new decision for that same observation (same stamp: a goal arrived while the lockstep simulator
held the robot) naming this node, the held inputs are answered then. The synchronizer itself drops a
repeated stamp, so such a status is checked here first.
"""

from __future__ import annotations

from amr_util.stamps import stamp_nanoseconds

NAVIGATOR_STATUS_TOPIC = "navigator/status"
STEPPINGS = ("lockstep", "realtime")
"""a controller's `stepping` parameter: how the world it drives steps, as the stack declares it (the simulator's
mode); a real robot is realtime."""


def stops_on_release(simulation: bool, stepping: str, status) -> bool:
    """Whether a controller that has just lost the charge sends one zero command. On a timer (the real robot's
    architecture): always. Answering observations (`simulation`): in a realtime world when the navigator gives the
    robot to nobody (no goal, no path, reached): the zero is the explicit hold, time goes on and nobody else answers;
    in lockstep never, as a command would step the world (the lockstep simulator holds the robot instead), nor when
    another controller takes over (its command answers the observation)."""
    return not simulation or (stepping == "realtime" and not status.controller)


class NavigatorGate:
    """Whether the navigator gave this controller the latest observation, and the one it did not give."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.in_charge = False
        """the latest status named this node."""
        self._held: tuple[int, tuple] | None = None

    def reset(self) -> None:
        self.in_charge = False
        self._held = None

    def admit(self, status, inputs: tuple) -> tuple[bool, bool]:
        """A synchronized set (the status and this node's inputs of one observation): (answer it, charge changed).
        A set not given to this node is held for a later decision on the same observation."""
        mine = status.controller == self.name
        changed = mine != self.in_charge
        self.in_charge = mine
        self._held = None if mine else (stamp_nanoseconds(status.header.stamp), inputs)
        return mine, changed

    def replay(self, status) -> tuple | None:
        """The held inputs, if `status` is a new decision for the held observation that names this node."""
        if self._held is None or stamp_nanoseconds(status.header.stamp) != self._held[0]:
            return None
        if status.controller != self.name:
            return None
        inputs, self._held = self._held[1], None
        self.in_charge = True
        return inputs

    def is_repeat(self, status) -> bool:
        """A status for the observation held here (the synchronizer would drop it as a repeated stamp)."""
        return self._held is not None and stamp_nanoseconds(status.header.stamp) == self._held[0]

    def route(self, status, answer, pair) -> None:
        """A status as it arrives: a new decision on the held observation answers it (``answer(*held)``) when it
        names this node, a repeat that does not is dropped, any other status goes to ``pair`` (the synchronizer)."""
        if self.is_repeat(status):
            held = self.replay(status)
            if held is not None:
                answer(*held)
            return
        pair(status)
