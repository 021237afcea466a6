"""lifecycle_manager: configures and activates `node_startup_order` in order, and takes them down in reverse.

The sequencing is amr_bringup.lifecycle_sequence.LifecycleSequencer; this module gives it
the lifecycle services of the managed nodes. Service calls block, so they run on a
worker thread while a MultiThreadedExecutor serves their responses.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Callable

import rclpy
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetAvailableTransitions, GetState
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from std_srvs.srv import Trigger

from amr_bringup.lifecycle_sequence import MANAGER_PARAMETERS, LifecycleSequencer, Step
from amr_util.managed_node import SpecifiedParameters
from amr_util.stop_signals import StopSignals

PARAMETERS = MANAGER_PARAMETERS
SHUTDOWN_BUDGET = 3.0  # s to bring the managed nodes down on Ctrl-C (launch escalates to SIGTERM after 5 s)


class ServiceLifecycleClient:
    """LifecycleClient over /<node>/get_state, get_available_transitions and change_state."""

    def __init__(self, node: Node, call_timeout: float) -> None:
        self._node, self._timeout = node, call_timeout
        self._group = ReentrantCallbackGroup()
        self._clients: dict[tuple[str, str], object] = {}

    def _client(self, name: str, service: str, service_type):
        key = (name, service)
        if key not in self._clients:
            self._clients[key] = self._node.create_client(service_type, f"{name}/{service}", callback_group=self._group)
        return self._clients[key]

    def _call(self, name: str, service: str, service_type, request):
        """The response, or None at once when the service is gone (a node that already exited)."""
        client = self._client(name, service, service_type)
        if not client.service_is_ready():
            return None
        return client.call(request, self._timeout)

    def wait_until_available(self, node: str, timeout: float) -> bool:
        return all(
            self._client(node, service, kind).wait_for_service(timeout_sec=timeout)
            for service, kind in (
                ("get_state", GetState),
                ("change_state", ChangeState),
                ("get_available_transitions", GetAvailableTransitions),
            )
        )

    def state(self, node: str) -> str | None:
        response = self._call(node, "get_state", GetState, GetState.Request())
        return None if response is None else response.current_state.label

    def available_transitions(self, node: str) -> list[str] | None:
        response = self._call(
            node, "get_available_transitions", GetAvailableTransitions, GetAvailableTransitions.Request()
        )
        return None if response is None else [t.transition.label for t in response.available_transitions]

    def change_state(self, node: str, transition: str) -> bool | None:
        request = ChangeState.Request(transition=Transition(label=transition))
        response = self._call(node, "change_state", ChangeState, request)
        return None if response is None else response.success


class LifecycleManager(SpecifiedParameters, Node):
    """Parameters: node_startup_order, wait_timeout, transition_timeout, autostart (PARAMETERS).

    Raises ValueError naming every bad or unknown parameter.
    """

    multithreaded_executor = True  # ~/startup and ~/shutdown block on lifecycle calls whose answers it must spin

    def __init__(self, before_activate: Callable[[str], None] = lambda node: None, **kwargs) -> None:
        super().__init__("lifecycle_manager", **kwargs)
        self.use_parameter_specs()
        self.declare_specs(PARAMETERS)
        problems = self.parameter_problems()
        if problems:
            self.destroy_node()
            raise ValueError("; ".join(problems))
        nodes = [n for n in self.get_parameter("node_startup_order").value if n]
        self.sequencer = LifecycleSequencer(
            ServiceLifecycleClient(self, self.get_parameter("transition_timeout").value),
            nodes,
            wait_timeout=self.get_parameter("wait_timeout").value,
            report=self._report,
            before_activate=before_activate,
        )
        self._busy = threading.Lock()
        self.startup_result: list[Step] | None = None
        group = ReentrantCallbackGroup()
        self.create_service(Trigger, "~/startup", self._on_startup, callback_group=group)
        self.create_service(Trigger, "~/shutdown", self._on_shutdown, callback_group=group)

    @property
    def started(self) -> bool:
        return bool(self.startup_result) and all(step.ok for step in self.startup_result)

    def startup(self) -> list[Step]:
        with self._busy:
            self.get_logger().info(f"bringing up {self.sequencer.nodes}")
            self.startup_result = self.sequencer.startup()
            if self.started:
                self.get_logger().info("all managed nodes are active")
            return self.startup_result

    def shutdown(self) -> list[Step]:
        """Takes down what is up, including what a startup still running has brought up so far."""
        self.sequencer.cancel_startup()
        with self._busy:
            return self.sequencer.shutdown()

    def _report(self, step: Step) -> None:
        if step.ok:
            self.get_logger().info(f"{step.transition} {step.node}: {step.detail}")
        else:
            self.get_logger().error(f"startup stopped at {step.transition} {step.node}: {step.detail}")

    def _on_startup(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        steps = self.startup()
        response.success = self.started
        response.message = steps[-1].detail if steps else "nothing to do"
        return response

    def _on_shutdown(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        steps = self.shutdown()
        response.success = all(step.ok for step in steps)
        response.message = "; ".join(f"{s.transition} {s.node}: {s.detail}" for s in steps) or "nothing to do"
        return response


def main(args=None) -> None:
    rclpy.init(args=sys.argv if args is None else args, signal_handler_options=SignalHandlerOptions.NO)
    try:
        manager = LifecycleManager()
    except ValueError as error:
        print(f"lifecycle_manager: {error}", file=sys.stderr)
        rclpy.shutdown()
        raise SystemExit(2) from None
    executor = MultiThreadedExecutor()
    executor.add_node(manager)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    signals = StopSignals()  # the first Ctrl-C / SIGTERM asks to stop, a second to stop now
    if manager.get_parameter("autostart").value:
        threading.Thread(target=manager.startup, daemon=True).start()
    while not signals.stop.wait(0.1):
        pass
    manager.get_logger().info("shutting down the managed nodes in reverse order")
    worker = threading.Thread(target=manager.shutdown, daemon=True)
    worker.start()
    deadline = time.monotonic() + SHUTDOWN_BUDGET
    while worker.is_alive() and not signals.hurry.is_set() and time.monotonic() < deadline:
        worker.join(0.1)
    if worker.is_alive():
        # `ros2 launch` signals every process at once: the managed nodes may be gone mid-call
        manager.get_logger().warning("not every managed node answered: leaving the rest as they are")
        sys.stdout.flush()
        os._exit(0)  # a thread is blocked in a service call; tearing the interpreter down under it aborts
    executor.shutdown()
    spinner.join(timeout=5.0)
    manager.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
