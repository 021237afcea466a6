"""The base of every node in the suite: a lifecycle node that survives bad transition requests
and whose parameters behave as ROS users expect.

rclpy 7.1.6 raises `RCLError: Transition is not registered` inside the executor when
/<node>/change_state asks for a transition the current state does not have (rclpy
issue 1209), which takes the whole process down. Here the request is checked against
the available transitions first and refused with success=false.

Parameters are declared from `ParameterSpec`s (amr_util.parameter_spec), each with a descriptor
of its own (type, description, range, read-only), so `ros2 param describe` tells the truth. A
bad value or an unknown key in a parameter file never kills the process in declare_parameter:
it is remembered, and configure fails listing every problem at once. While the node is
configured, a set of a live parameter is validated and applied at once (the node's
`apply_live` hook), and a set of a structural one is refused with the reason; nothing is
accepted and then ignored.

Lifecycle edges are handled here once for every node: `shutdown` from any state runs the node's own
`on_deactivate` (if active: a controller's zero command goes out, timers stop, publishers are disabled)
and `on_cleanup` (if configured: subscriptions, services and publishers destroyed), so nothing is
published afterwards; a node writes no `on_shutdown` of its own. Services made with
`create_active_service` answer only while the node is active and refuse clearly otherwise.

What a node creates while it configures (subscriptions, publishers, services, clients, timers, guard conditions)
is tracked here, and `ManagedNode.on_cleanup` destroys it, the last made first: a node's own `on_cleanup` resets its
fields and ends with `return super().on_cleanup(state)` (destroying an entity twice is harmless).

On simulated time (use_sim_time) a node's subscriptions and lifecycle publishers have no QoS-event handlers
(`QUIET_SUBSCRIPTION`, `QUIET_PUBLISHER`; a publisher's defaults are two waitables too): every
publisher of a simulated stack is the suite's own, and rclpy's default handlers are two waitables per subscription,
which its executor visits at every wake-up of the node (20 of a navigator's 22 waitables; a node with 10
subscriptions spent 435 us a callback with them, 279 us without:
docs/decisions/2026-11-29-fleet-ros-layer.md). On wall time (a real robot's drivers) the default handlers stay, so
an incompatible QoS or type is reported.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.exceptions import InvalidTopicNameException
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.expand_topic_name import expand_topic_name
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from rclpy.validate_full_topic_name import validate_full_topic_name

from amr_util.executors import executor_for
from amr_util.parameter_spec import ParameterSpec
from amr_util.robot_description import (
    DEFAULT_FILE,
    RobotDescriptionError,
    default_robot,
    load_robot_description,
    robot_parameters,
)
from amr_util.stop_signals import StopSignals
from amr_util.sync import SyncError
from amr_util.throttle import Throttle

PARAMETER_TYPES = {
    "bool": Parameter.Type.BOOL,
    "int": Parameter.Type.INTEGER,
    "float": Parameter.Type.DOUBLE,
    "str": Parameter.Type.STRING,
    "bool_array": Parameter.Type.BOOL_ARRAY,
    "int_array": Parameter.Type.INTEGER_ARRAY,
    "float_array": Parameter.Type.DOUBLE_ARRAY,
    "str_array": Parameter.Type.STRING_ARRAY,
}
CONFIGURED_STATES = ("inactive", "active")
ALWAYS_KNOWN = ("use_sim_time", "autostart", "start_type_description_service")
"""Parameters every rclpy node declares itself (plus ours), never reported as unknown."""
ROBOT_DESCRIPTION = "robot_description"
"""The parameter a node with robot facts among its parameters (robot_radius, lidar_x, robot.radius, ...) declares."""
REFUSAL_LOG_PERIOD = 2.0
"""s between two logs of one kind of refusal: a request refused because the node is not active, an input message the
synchronizer could not take (feed_synchronizer)."""
WARNING_PERIOD = 2.0
"""s of wall time (steady, as rclpy's throttle_duration_sec) between two logs of one warning text (warn_throttled)."""
QUIET_SUBSCRIPTION = SubscriptionEventCallbacks(use_default_callbacks=False)
"""A subscription's event callbacks with no handler (no waitable in the node's wait set)."""
QUIET_PUBLISHER = PublisherEventCallbacks(use_default_callbacks=False)
"""A publisher's event callbacks with no handler."""


def topic_name_problem(name: str) -> str | None:
    """Why `name` is not a valid ROS topic name (relative, absolute or private), or None."""
    try:
        validate_full_topic_name(expand_topic_name(name, "node", "/"))
    except (InvalidTopicNameException, ValueError, RuntimeError) as problem:
        return f"not a valid topic name ({problem})".replace("\n", " ")
    return None


def descriptor_of(spec: ParameterSpec) -> ParameterDescriptor:
    """A new descriptor for one parameter (rclpy writes the name into it: never share one)."""
    descriptor = ParameterDescriptor(
        name=spec.name,
        type=PARAMETER_TYPES[spec.kind].value,
        read_only=spec.read_only,
        description=spec.description
        + ("" if spec.live or spec.read_only else " (structural: set it while unconfigured)"),
        additional_constraints=spec.constraint,
    )
    numeric = spec.kind.removesuffix("_array")
    if numeric == "float" and (spec.minimum is not None or spec.maximum is not None):
        descriptor.floating_point_range = [
            FloatingPointRange(
                from_value=float(-1e308 if spec.minimum is None else spec.minimum),
                to_value=float(1e308 if spec.maximum is None else spec.maximum),
                step=0.0,
            )
        ]
    elif numeric == "int" and (spec.minimum is not None or spec.maximum is not None):
        descriptor.integer_range = [
            IntegerRange(
                from_value=int(-(2**63) if spec.minimum is None else spec.minimum),
                to_value=int(2**63 - 1 if spec.maximum is None else spec.maximum),
                step=0,
            )
        ]
    return descriptor


class SpecifiedParameters:
    """Parameters declared from ParameterSpecs, for any rclpy Node (mixed in before the Node class).

    `parameters_in_force` says when structural parameters are refused and live ones applied
    (a lifecycle node: once configured; a plain node: always).
    """

    parameters_in_force = True

    def use_parameter_specs(self) -> None:
        """Start checking sets against specs (call once, from the node's __init__)."""
        self._specs: dict[str, ParameterSpec] = {}
        self._parameter_problems: dict[str, str] = {}
        self._declaring = False
        self._set_names: set[str] = set()
        self.add_pre_set_parameters_callback(self._widen_parameters)
        self.add_on_set_parameters_callback(self._on_set_parameters)

    def declare_specs(self, specs: Sequence[ParameterSpec]) -> None:
        """Declare each parameter with its own descriptor, taking its value from the overrides.

        A given value of the wrong type or out of range is not fatal here: the default is
        declared, and the problem is kept for configure to report with all the others.
        """
        overrides = self._parameter_overrides  # -p / --params-file values (rclpy has no public accessor)
        robot_keys = robot_parameters(default_robot()).keys()
        if ROBOT_DESCRIPTION not in self._specs and any(spec.name in robot_keys for spec in specs):
            specs = [
                *specs,
                ParameterSpec(
                    ROBOT_DESCRIPTION,
                    DEFAULT_FILE,
                    "the robot description (a file in share/amr_util/config/robot, or a "
                    "path): the robot's facts (robot_radius, lidar_x, robot.*, lidar mount) not given to this node",
                    check=_robot_description_problem,
                    nonempty=True,
                ),
            ]
        self._declaring = True
        try:
            self._declare_each(specs, overrides)
        finally:
            self._declaring = False

    def _declare_each(self, specs: Sequence[ParameterSpec], overrides: dict) -> None:
        for spec in specs:
            value, problem = spec.default, None
            if spec.name in overrides:
                given = overrides[spec.name].value
                if given is None and spec.kind.endswith("_array"):  # rcl reads `[]` in a YAML file as not set
                    given = []
                try:
                    value = spec.coerce(given)
                except ValueError as error:
                    problem = str(error)
            self._specs[spec.name] = spec
            if value == []:  # rclpy infers a byte array from an empty list: declare the type, then set
                self.declare_parameter(spec.name, PARAMETER_TYPES[spec.kind], descriptor_of(spec), ignore_override=True)
                self.set_parameters([Parameter(spec.name, PARAMETER_TYPES[spec.kind], value)])
            else:
                self.declare_parameter(spec.name, value, descriptor_of(spec), ignore_override=True)
            if problem:  # after declaring: a successful set clears a key's problem
                self._parameter_problems[spec.name] = problem

    def parameter_values(self) -> dict:
        """{name: value} of every declared spec but `robot_description`, whose robot facts stand for those of
        the node's parameters never given (neither in its files, on its command line, nor set since)."""
        values = {name: self.get_parameter(name).value for name in self._specs if name != ROBOT_DESCRIPTION}
        if ROBOT_DESCRIPTION in self._specs:
            given = set(self._parameter_overrides) | self._set_names
            try:
                robot = robot_parameters(load_robot_description(self.get_parameter(ROBOT_DESCRIPTION).value))
            except RobotDescriptionError:
                return values  # reported by parameter_problems
            values.update({name: value for name, value in robot.items() if name in values and name not in given})
        return values

    def parameter_problems(self) -> list[str]:
        """Every bad value and unknown key given to this node, one line each (empty when all is well)."""
        problems = list(self._parameter_problems.values())
        known = set(self._specs) | set(ALWAYS_KNOWN) | set(self._parameters)
        unknown = sorted(
            name for name in self._parameter_overrides if name not in known and not name.startswith("qos_overrides.")
        )
        for name in unknown:
            problems.append(f"{name}: unknown parameter (known: {', '.join(self.known_parameters(name))})")
        return problems

    def known_parameters(self, unknown: str) -> list[str]:
        """The names to suggest for an unknown one: those sharing its dotted prefix, else all."""
        prefix = unknown.rpartition(".")[0]
        near = sorted(name for name in self._specs if prefix and name.startswith(prefix + "."))
        return near or sorted(self._specs)

    def fail_configure(self, problems: Sequence[str]) -> TransitionCallbackReturn:
        """Log every problem of a failed configure in one line each, and fail the transition."""
        for problem in problems:
            self.get_logger().error(f"configure failed: {problem}")
        return TransitionCallbackReturn.FAILURE

    def apply_live(self, changes: dict) -> None:
        """Apply live parameter changes while configured; raise ValueError to refuse them.

        Nodes with live parameters override this (validate the whole new configuration, then swap
        it in); the default refuses, so a node cannot accept what it would not use.
        """
        raise ValueError(f"{', '.join(changes)}: this node applies no parameter while configured")

    def _widen_parameters(self, parameters: list[Parameter]) -> list[Parameter]:
        """An integer for a float parameter (YAML `1`, `ros2 param set ... 1`) is that float; [] takes the spec's
        type."""
        widened = []
        for parameter in parameters:
            spec = self._specs.get(parameter.name)
            kind = PARAMETER_TYPES.get(spec.kind) if spec else None
            value = parameter.value
            if kind == Parameter.Type.DOUBLE and parameter.type_ == Parameter.Type.INTEGER:
                parameter = Parameter(parameter.name, kind, float(value))
            elif (
                kind is not None
                and kind.name.endswith("ARRAY")
                and isinstance(value, (list, tuple))
                and (
                    not value
                    or (kind == Parameter.Type.DOUBLE_ARRAY and parameter.type_ == Parameter.Type.INTEGER_ARRAY)
                )
            ):
                parameter = Parameter(parameter.name, kind, [float(v) for v in value] if value else [])
            widened.append(parameter)
        return widened

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        """Validate every set; while configured, apply live ones and refuse structural ones with the reason."""
        configured = self.parameters_in_force and not self._declaring
        changes = {}
        for parameter in parameters:
            spec = self._specs.get(parameter.name)
            if spec is None or parameter.type_ == Parameter.Type.NOT_SET:  # not ours, or being declared by type
                continue
            try:
                value = spec.coerce(parameter.value)
            except ValueError as problem:
                return SetParametersResult(successful=False, reason=str(problem))
            if configured and not spec.live:
                return SetParametersResult(
                    successful=False, reason=(f"{spec.name} is read-only while configured; cleanup, set, configure")
                )
            changes[spec.name] = value
            self._parameter_problems.pop(spec.name, None)
            if not self._declaring:
                self._set_names.add(spec.name)
        if configured and changes:
            try:
                self.apply_live(changes)
            except ValueError as problem:
                return SetParametersResult(successful=False, reason=str(problem))
            self.get_logger().info("applied " + ", ".join(f"{k} = {v!r}" for k, v in changes.items()))
        return SetParametersResult(successful=True)


def _robot_description_problem(name: str) -> str | None:
    try:
        load_robot_description(name)
    except RobotDescriptionError as error:
        return str(error)
    return None


class ManagedNode(SpecifiedParameters, LifecycleNode):
    """A LifecycleNode whose change_state service refuses invalid transitions instead of crashing."""

    def __init__(self, node_name: str, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.declare_parameter(
            "autostart",
            False,
            ParameterDescriptor(description="configure and activate at start, without a lifecycle manager"),
        )
        self._forward_change_state = self._service_change_state.callback
        self._service_change_state.callback = self._on_change_state_request
        self._warnings = Throttle(WARNING_PERIOD)
        self._configured_entities: list[tuple[Callable[[Any], Any], Any]] = []
        """(destroy, entity) of what was created while configuring: destroyed by on_cleanup."""
        self.use_parameter_specs()

    def _track(self, entity, destroy: Callable[[Any], Any]):
        """`entity`, kept for on_cleanup when made while configuring (rclpy's own, made in __init__, are not)."""
        if getattr(self, "_configured_entities", None) is not None and self.state_label == "configuring":
            self._configured_entities.append((destroy, entity))
        return entity

    def create_publisher(self, *args, **kwargs):
        return self._track(super().create_publisher(*args, **kwargs), self.destroy_publisher)

    def create_service(self, *args, **kwargs):
        return self._track(super().create_service(*args, **kwargs), self.destroy_service)

    def create_client(self, *args, **kwargs):
        return self._track(super().create_client(*args, **kwargs), self.destroy_client)

    def create_timer(self, *args, **kwargs):
        return self._track(super().create_timer(*args, **kwargs), self.destroy_timer)

    def create_guard_condition(self, *args, **kwargs):
        return self._track(super().create_guard_condition(*args, **kwargs), self.destroy_guard_condition)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Destroys what the node created while configuring, the last made first (a node's own on_cleanup ends
        with `return super().on_cleanup(state)`); then rclpy's (its managed entities' on_cleanup)."""
        while self._configured_entities:
            destroy, entity = self._configured_entities.pop()
            destroy(entity)
        return super().on_cleanup(state)

    def create_subscription(self, msg_type, topic, callback, qos_profile, *, event_callbacks=None, **kwargs):
        """As rclpy's; on simulated time without QoS-event handlers unless `event_callbacks` are given."""
        if event_callbacks is None and self.get_parameter("use_sim_time").value is True:
            event_callbacks = QUIET_SUBSCRIPTION
        subscription = super().create_subscription(
            msg_type, topic, callback, qos_profile, event_callbacks=event_callbacks, **kwargs
        )
        return self._track(subscription, self.destroy_subscription)

    def create_lifecycle_publisher(self, msg_type, topic, qos_profile, *, event_callbacks=None, **kwargs):
        """As rclpy's; on simulated time without QoS-event handlers unless `event_callbacks` are given."""
        if event_callbacks is None and self.get_parameter("use_sim_time").value is True:
            event_callbacks = QUIET_PUBLISHER
        publisher = super().create_lifecycle_publisher(
            msg_type, topic, qos_profile, event_callbacks=event_callbacks, **kwargs
        )
        return self._track(publisher, self.destroy_lifecycle_publisher)

    @property
    def parameters_in_force(self) -> bool:
        """Configured: what the parameters shaped is built, so structural ones may not change."""
        return self.state_label in CONFIGURED_STATES

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
                f"refused transition {asked!r} from state {self.state_label!r}; available: {sorted(available.values())}"
            )
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
            Transition.TRANSITION_UNCONFIGURED_SHUTDOWN: self.trigger_shutdown,
            Transition.TRANSITION_INACTIVE_SHUTDOWN: self.trigger_shutdown,
            Transition.TRANSITION_ACTIVE_SHUTDOWN: self.trigger_shutdown,
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

    def shut_down(self) -> bool:
        """The `shutdown` transition from whatever state the node is in (unconfigured, inactive, active)."""
        if self.state_label not in ("unconfigured", "inactive", "active"):
            return False
        return self.trigger_shutdown() == TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Shutdown from any state, for every node: an active node goes through its own on_deactivate first
        (zero command, timers stopped, publishers disabled), a configured one through its on_cleanup (its
        entities destroyed). A step that raises is logged and the next one still runs: the node ends
        finalized, publishing nothing."""
        steps = []
        if state.label == "active":
            steps.append(("deactivate", self.on_deactivate))
        if state.label in CONFIGURED_STATES:
            steps.append(("cleanup", self.on_cleanup))
        for name, step in steps:
            try:
                step(state)
            except Exception as error:  # shutting down must finish: the process may be going away
                self.get_logger().error(f"shutdown: {name} failed: {type(error).__name__}: {error}")
        for entity in list(self._managed_entities):  # anything a cleanup left behind is silenced
            entity.on_deactivate(state)
        self.get_logger().info(f"shut down from {state.label}")
        return TransitionCallbackReturn.SUCCESS

    def create_active_service(self, service_type, name: str, callback: Callable[[Any, Any], Any], **kwargs):
        """A service that answers only while the node is active (as nav2's map_server does). Otherwise the request
        is refused: `success` false and the reason in `message` where the response has them, else the empty
        response; either way a warning names the state."""

        def answer_when_active(request, response):
            if self.state_label == "active":
                return callback(request, response)
            reason = f"{self.get_name()} is {self.state_label}: {name} answers only while active"
            self.get_logger().warning(f"refused a request: {reason}", throttle_duration_sec=REFUSAL_LOG_PERIOD)
            if hasattr(response, "success"):
                response.success = False
            if hasattr(response, "message"):
                response.message = reason
            return response

        return self.create_service(service_type, name, answer_when_active, **kwargs)

    def warn_throttled(self, text: str) -> bool:
        """`text` logged as a warning unless the same text was within WARNING_PERIOD s of wall time (each distinct
        warning on its own clock: rclpy's throttle_duration_sec keys on the call site, so one line's different
        warnings would hide each other); the logger is asked only for a message that goes out (a warning a node
        repeats every step costs a dictionary lookup). Returns whether it went out."""
        if not self._warnings(text):
            return False
        self.get_logger().warning(text)
        return True

    def feed_synchronizer(self, sync, index: int, message, warn: Callable[[str], object]) -> None:
        """An input message into its synchronizer (amr_util.sync.ApproximateTimeSynchronizer: `index` its input)
        while the node is active, ignored otherwise: a malformed or negative stamp said through `warn` (the node's
        throttled warning), any other error of the synchronizer's logged; nothing raised out of the subscription's
        callback (the synchronized set's own callback logs its own errors)."""
        if self.state_label != "active" or sync is None:
            return
        try:
            sync.add_stamped(index, message)
        except SyncError as error:  # a malformed or negative stamp
            warn(str(error))
        except Exception as error:
            self.get_logger().error(
                f"input dropped: {type(error).__name__}: {error}", throttle_duration_sec=REFUSAL_LOG_PERIOD
            )


SIGNAL_CHECK_PERIOD = 0.1  # seconds between chances for Ctrl-C / SIGTERM to be seen


def spin_nodes(nodes: Sequence[LifecycleNode], executor: Executor) -> None:
    """Spin until Ctrl-C or SIGTERM, then bring the nodes down in reverse order.

    The context must still be valid during the shutdown, so that deactivation can
    publish its last messages (a zero velocity): init with SignalHandlerOptions.NO, and
    spin in slices so that Python's own signal handlers get to run. The handlers only
    set a flag: a KeyboardInterrupt raised from a handler is swallowed when the signal
    lands while a __del__ runs (seen under load: the node then spun on until killed).
    """
    for node in nodes:
        executor.add_node(node)
    for node in nodes:
        if isinstance(node, ManagedNode):
            node.autostart()
    stop = StopSignals().stop
    try:
        while rclpy.ok(context=executor.context) and not stop.is_set():
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


def run(node_factory: Callable[[], LifecycleNode], *, args: Sequence[str] | None = None) -> None:
    """The body of every node's main(): init, build, spin on amr_util.executors.executor_for's executor, shut
    down."""
    rclpy.init(args=list(sys.argv if args is None else args), signal_handler_options=SignalHandlerOptions.NO)
    node = node_factory()
    executor = executor_for(node)
    spin_nodes([node], executor)
