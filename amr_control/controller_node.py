"""What the path follower and wall follower nodes do around their controllers, in one place (no control logic).

- **Answering an observation.** In simulation (`simulation: true`) a command is computed at once, one per
  synchronized observation (lockstep: exactly one command answers each). On a real robot (`simulation: false`) the
  observation is only kept; a timer computes every `dt` from the newest one, publishes the last command again
  between observations (the sensors slower than dt), and zero, with a throttled warning, when none came for
  `stale_timeout` (or none yet).
- **Under a navigator** (`navigated: true`): its status is a third synchronized input; the observation is answered
  only when the status names this node (amr_control.navigated.NavigatorGate), and losing the charge stops the robot
  once where `stops_on_release` says so. The hand-over is logged.
- **The command** goes out as the robot takes it (`velocity_command`: TwistStamped in simulation, Twist to a real
  TurtleBot3, `flip_angular_sign`), stamped from the node clock; deactivation sends zero.

A node built on it sets `config` (its simulation, stepping, dt, stale_timeout, flip_angular_sign), creates
`_publisher` when configured, and gives `_compute(*inputs)` (one observation's command: it calls `_publish`) and
`_drives()` (whether its timer commands now).
"""

from __future__ import annotations

from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.time import Time

from amr_control.navigated import NavigatorGate, stops_on_release
from amr_util.managed_node import ManagedNode
from amr_util.messages import velocity_command


class ControllerNode(ManagedNode):
    """A lifecycle node that drives the robot by a controller: see the module docstring."""

    INPUTS = "inputs"
    """The observation's topics, as the stale warning names them ("/odometry + /scan")."""

    def __init__(self, node_name: str, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.config = None
        self.last_command = None
        """The latest command computed (the controller's own type: v, w)."""
        self.commands_sent = 0
        self._publisher = None
        self._timer = None
        self._latest: tuple | None = None  # the newest observation not yet computed (real robot)
        self._latest_time: Time | None = None  # when an observation last came (real robot)
        self._gate = NavigatorGate(self.get_name())

    def _compute(self, *inputs) -> None:
        raise NotImplementedError

    def _drives(self) -> bool:
        raise NotImplementedError

    # -- lifecycle ------------------------------------------------------------------------------

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._gate.reset()
        self._latest = self._latest_time = None
        if not self.config.simulation:
            self._timer = self.create_timer(self.config.dt, self._on_timer)
        return super().on_activate(state)

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._publish(0.0, 0.0)
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._publisher = None
        return super().on_cleanup(state)  # destroys what configure made

    # -- observations ---------------------------------------------------------------------------

    def _answer(self, *inputs) -> None:
        """An observation this node answers: computed now (simulation) or kept for the timer (real robot)."""
        if self.config.simulation:
            self._compute(*inputs)
        else:
            self._latest = inputs
            self._latest_time = self.get_clock().now()

    def _admit(self, status, inputs: tuple) -> bool:
        """A navigated observation (the navigator's status and this node's inputs): whether the status gives it to
        this node. On a change of charge it is logged; on losing it the kept observation is dropped and the robot
        stopped once where stops_on_release says so."""
        mine, changed = self._gate.admit(status, inputs)
        if changed:
            self.get_logger().info(
                f"navigator: {status.mode}: "
                + ("driving" if mine else f"handing over to {status.controller or 'nobody'} ({status.reason})")
            )
            if not mine:
                self._latest = None
                if stops_on_release(self.config.simulation, self.config.stepping, status):
                    self._publish(0.0, 0.0)  # the robot stops at the hand-over; the next controller takes it from here
        return mine

    def _on_timer(self) -> None:
        """Every dt (real robot): a command from a new observation, the last command again between observations,
        zero when none came for stale_timeout; nothing while this node does not drive."""
        if not self._drives():
            return
        if self._latest_time is None or self._is_stale():
            self.warn_throttled(f"no {self.INPUTS} for {self.config.stale_timeout} s: stopping")
            self._publish(0.0, 0.0)
            return
        if self._latest is None:  # the sensors are slower than dt: hold the last command
            last = self.last_command
            self._publish(last.v, last.w) if last is not None else self._publish(0.0, 0.0)
            return
        inputs, self._latest = self._latest, None
        self._compute(*inputs)

    def _is_stale(self) -> bool:
        age = (self.get_clock().now() - self._latest_time).nanoseconds * 1e-9
        return age > self.config.stale_timeout

    # -- output ---------------------------------------------------------------------------------

    def _publish(self, v: float, w: float) -> None:
        if self._publisher is None:
            return
        self._publisher.publish(
            velocity_command(
                v,
                w,
                stamped=self.config.simulation,
                flip_angular_sign=self.config.flip_angular_sign,
                stamp=self.get_clock().now().to_msg(),
            )
        )
        self.commands_sent += 1
