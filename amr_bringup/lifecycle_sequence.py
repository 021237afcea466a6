"""Bringing managed nodes up in order and down in reverse, with no ROS in sight.

The sequencer asks before it acts: a transition is requested only when the node's
current state offers it (rclpy 7.1.6 raises inside the node's executor on an
invalid one, rclpy issue 1209). The first failure stops the startup and says which
node, which transition and why; the nodes already up stay up until shutdown.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

from amr_util.parameter_spec import ParameterSpec

MANAGER_PARAMETERS = (
    ParameterSpec(
        "node_startup_order",
        [""],
        "lifecycle nodes to configure and activate, in this order (taken down in reverse)",
        kind="str_array",
        read_only=True,
    ),
    ParameterSpec(
        "wait_timeout", 30.0, "s to wait for a node's lifecycle services", minimum=0.1, maximum=3600.0, read_only=True
    ),
    ParameterSpec(
        "transition_timeout", 15.0, "s for one lifecycle service call", minimum=0.1, maximum=3600.0, read_only=True
    ),
    ParameterSpec("autostart", True, "bring the nodes up at start (else wait for ~/startup)", read_only=True),
)
"""The lifecycle manager's parameters (read-only: the sequence is built from them at start); a stack file's
`lifecycle_manager:` section is checked against them too."""

UP = ("configure", "activate")
DOWN = ("deactivate", "cleanup")
WAIT_SLICE = 0.25  # s between looks at a cancel request while waiting for a node's services
STATE_AFTER = {"configure": "inactive", "activate": "active", "deactivate": "inactive", "cleanup": "unconfigured"}


class LifecycleClient(Protocol):
    """What the sequencer needs from a node's lifecycle services."""

    def wait_until_available(self, node: str, timeout: float) -> bool: ...
    def state(self, node: str) -> str | None: ...
    def available_transitions(self, node: str) -> list[str] | None: ...
    def change_state(self, node: str, transition: str) -> bool | None: ...


@dataclass(frozen=True)
class Step:
    node: str
    transition: str
    ok: bool
    detail: str = ""


class LifecycleSequencer:
    """Drives a list of nodes through configure/activate and back."""

    def __init__(
        self,
        client: LifecycleClient,
        nodes: Sequence[str],
        *,
        wait_timeout: float,
        report: Callable[[Step], None] = lambda step: None,
        before_activate: Callable[[str], None] = lambda node: None,
    ) -> None:
        """before_activate(node) runs just before a node is activated (a recorder catching up with its topics)."""
        if not nodes:
            raise ValueError("node_startup_order is empty: name the nodes to manage")
        if len(set(nodes)) != len(nodes):
            raise ValueError(f"node_startup_order names a node twice: {list(nodes)}")
        self.client, self.nodes, self.wait_timeout, self.report = client, list(nodes), wait_timeout, report
        self.before_activate = before_activate
        self._cancelled = threading.Event()

    def cancel_startup(self) -> None:
        """Make a running startup stop before its next wait or transition (a stop arrived mid-startup)."""
        self._cancelled.set()

    def startup(self) -> list[Step]:
        """Configure and activate every node in order; stops at the first failure (last step not ok)."""
        self._cancelled.clear()
        steps: list[Step] = []
        for node in self.nodes:
            if not self._wait_until_available(node):
                detail = (
                    "startup cancelled"
                    if self._cancelled.is_set()
                    else f"lifecycle services of {node} not available after {self.wait_timeout} s"
                )
                return self._record(steps, Step(node, "wait", False, detail))
            remaining = {"inactive": UP[1:], "active": ()}.get(self.client.state(node), UP)
            for transition in remaining:
                if self._cancelled.is_set():
                    return self._record(steps, Step(node, transition, False, "startup cancelled"))
                if transition == "activate":
                    self.before_activate(node)
                step = self._record(steps, self._transition(node, transition))[-1]
                if not step.ok:
                    return steps
        return steps

    def _wait_until_available(self, node: str) -> bool:
        """In slices, so that a cancel request is seen within WAIT_SLICE."""
        deadline = time.monotonic() + self.wait_timeout
        while not self._cancelled.is_set():
            slice_end = min(deadline, time.monotonic() + WAIT_SLICE)
            if self.client.wait_until_available(node, max(0.0, slice_end - time.monotonic())):
                return True
            if self._cancelled.wait(max(0.0, slice_end - time.monotonic())) or time.monotonic() >= deadline:
                return False
        return False

    def shutdown(self) -> list[Step]:
        """Deactivate and clean up in reverse order, as far as each node's state allows; never stops early."""
        steps: list[Step] = []
        for node in reversed(self.nodes):
            for transition in DOWN:
                available = self.client.available_transitions(node)
                if available is None or transition not in available:
                    continue
                self._record(steps, self._transition(node, transition))
        return steps

    def _transition(self, node: str, transition: str) -> Step:
        state = self.client.state(node)
        if state is None:
            return Step(node, transition, False, f"{node} did not answer get_state")
        available = self.client.available_transitions(node)
        if available is None:
            return Step(node, transition, False, f"{node} did not answer get_available_transitions")
        if transition not in available:
            return Step(
                node, transition, False, f"{node} is {state!r}, which offers {sorted(available)}, not {transition!r}"
            )
        result = self.client.change_state(node, transition)
        if result is None:
            return Step(node, transition, False, f"{node} did not answer change_state({transition})")
        if not result:
            return Step(node, transition, False, f"{node} refused or failed {transition} (see its log)")
        return Step(node, transition, True, f"{node} is {STATE_AFTER[transition]}")

    def _record(self, steps: list[Step], step: Step) -> list[Step]:
        steps.append(step)
        self.report(step)
        return steps
