"""The base of every node in the suite: a lifecycle node that survives bad transition requests.

rclpy 7.1.6 raises `RCLError: Transition is not registered` inside the executor when
/<node>/change_state asks for a transition the current state does not have (rclpy
issue 1209), which takes the whole process down. Here the request is checked against
the available transitions first and refused with success=false.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import rclpy
from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from rclpy.executors import ExternalShutdownException, Executor, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.lifecycle import LifecycleNode, TransitionCallbackReturn
from rclpy.signals import SignalHandlerOptions


class ManagedNode(LifecycleNode):
    """A LifecycleNode whose change_state service refuses invalid transitions instead of crashing."""

    def __init__(self, node_name: str, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.declare_parameter("autostart", False)
        self._forward_change_state = self._service_change_state.callback
        self._service_change_state.callback = self._on_change_state_request

    def available_transition_ids(self) -> dict[int, str]:
        """{transition id: label} of the transitions the current state allows."""
        return {entry[0]: entry[1] for entry in self._state_machine.available_transitions}

    @property
    def state_label(self) -> str:
        return self._state_machine.current_state[1]

    def _on_change_state_request(self, request: ChangeState.Request, response: ChangeState.Response):
        available = self.available_transition_ids()
        label = request.transition.label
        allowed = label in available.values() if label else request.transition.id in available
        if not allowed:
            asked = label or f"id {request.transition.id}"
            self.get_logger().warning(
                f"refused transition {asked!r} from state {self.state_label!r}; "
                f"available: {sorted(available.values())}")
            response.success = False
            return response
        return self._forward_change_state(request, response)

    def try_transition(self, transition_id: int) -> bool:
        """Trigger a transition from inside the process; False if the state does not allow it."""
        if transition_id not in self.available_transition_ids():
            return False
        triggers: dict[int, Callable] = {
            Transition.TRANSITION_CONFIGURE: self.trigger_configure,
            Transition.TRANSITION_ACTIVATE: self.trigger_activate,
            Transition.TRANSITION_DEACTIVATE: self.trigger_deactivate,
            Transition.TRANSITION_CLEANUP: self.trigger_cleanup,
        }
        trigger = triggers.get(transition_id)
        if trigger is None:
            return False
        return trigger() == TransitionCallbackReturn.SUCCESS

    def autostart(self) -> None:
        """Configure and activate now when the `autostart` parameter asks for it."""
        if self.get_parameter("autostart").value:
            if self.try_transition(Transition.TRANSITION_CONFIGURE):
                self.try_transition(Transition.TRANSITION_ACTIVATE)

    def shut_down_cleanly(self) -> None:
        """Deactivate and clean up as far as the current state allows (zero commands go out first)."""
        self.try_transition(Transition.TRANSITION_DEACTIVATE)
        self.try_transition(Transition.TRANSITION_CLEANUP)


SIGNAL_CHECK_PERIOD = 0.1  # seconds between chances for Ctrl-C / SIGTERM to be seen


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def spin_nodes(nodes: Sequence[LifecycleNode], executor: Executor) -> None:
    """Spin until Ctrl-C or SIGTERM, then bring the nodes down in reverse order.

    The context must still be valid during the shutdown, so that deactivation can
    publish its last messages (a zero velocity): init with SignalHandlerOptions.NO, and
    spin in slices so that Python's own signal handlers get to run.
    """
    for node in nodes:
        executor.add_node(node)
    for node in nodes:
        if isinstance(node, ManagedNode):
            node.autostart()
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        while rclpy.ok(context=executor.context):
            executor.spin_once(timeout_sec=SIGNAL_CHECK_PERIOD)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        for node in reversed(nodes):
            if isinstance(node, ManagedNode) and rclpy.ok():
                node.shut_down_cleanly()
            node.destroy_node()
        executor.shutdown()
        if rclpy.ok():
            rclpy.try_shutdown()


def run(node_factory: Callable[[], LifecycleNode], *, multithreaded: bool = False,
        args: Sequence[str] | None = None) -> None:
    """The body of every node's main(): init, build, spin, shut down."""
    rclpy.init(args=list(sys.argv if args is None else args), signal_handler_options=SignalHandlerOptions.NO)
    executor = MultiThreadedExecutor() if multithreaded else SingleThreadedExecutor()
    spin_nodes([node_factory()], executor)


def share_directory(package: str) -> Path:
    """share/<package> from the ament index, or under this Python's prefix in a venv with no ROS sourced."""
    try:
        return Path(get_package_share_directory(package))
    except (PackageNotFoundError, OSError):
        return Path(sys.prefix) / "share" / package
