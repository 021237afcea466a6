"""wall_follower: synchronized /odometry + /scan in, /cmd_vel out (seed 002).

Simulation (`simulation: true`, lockstep): a command is computed in the synchronized
callback, one per observation, published as TwistStamped. Real robot (`simulation:
false`, seed 5.2.2): the callback only stores the latest pair; a timer computes every
dt and publishes Twist, and publishes zero velocity when no new pair came for
`stale_timeout`. The lockstep simulator holds the robot when no command comes, so the
stale watchdog runs in the timer architecture only.

With `navigated`, the navigator's navigator/status (amr_interfaces/NavigatorStatus, one per
observation, stamped like the scan) is a third synchronized input: the follower answers only the
observations the navigator gives it (amr_control.navigated), so in lockstep exactly one command
answers each observation across every hand-over. On the real robot (timer), losing the charge sends
one zero command; the timer is silent until the navigator names this node again. In simulation with
`stepping: realtime` (the simulator on its timer) it sends one when the navigator gives the robot to nobody.
"""

from __future__ import annotations

from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.time import Time
from sensor_msgs.msg import LaserScan

from amr_control.controller_node import ControllerNode
from amr_control.navigated import NAVIGATOR_STATUS_TOPIC
from amr_control.wall_follower import Command, WallFollower
from amr_control.wall_follower_config import WallFollowerConfig
from amr_interfaces.msg import NavigatorStatus, WallFollowerStatus
from amr_util.managed_node import WARNING_PERIOD, run
from amr_util.messages import scan_data
from amr_util.parameter_spec import ConfigError
from amr_util.qos import SENSOR_DATA, reliable
from amr_util.sync import ApproximateTimeSynchronizer

ODOMETRY, SCAN, STATUS = 0, 1, 2


class WallFollowerNode(ControllerNode):
    """Wires WallFollower and ApproximateTimeSynchronizer to topics (amr_control.controller_node: the observations
    answered, the timer, the navigator's charge, the command); holds no control logic."""

    INPUTS = "synchronized /odometry + /scan"

    def __init__(self, **kwargs) -> None:
        super().__init__("wall_follower", **kwargs)
        self.declare_specs(WallFollowerConfig.parameter_specs())
        self.config: WallFollowerConfig | None = None
        self.controller: WallFollower | None = None
        self.last_command: Command | None = None
        self._sync: ApproximateTimeSynchronizer | None = None
        self._inputs = []
        self.configure_error = ""

    # -- lifecycle ------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if not problems:
            try:
                config = WallFollowerConfig.from_params(self.parameter_values())
                controller = WallFollower(config)
            except ConfigError as error:
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            return self.fail_configure(problems)
        self.config, self.controller = config, controller
        inputs, callback = (3, self._on_navigated_triple) if config.navigated else (2, self._on_pair)
        self._sync = ApproximateTimeSynchronizer(
            inputs,
            config.sync_slop,
            config.sync_queue_size,
            callback,
            jump_threshold=config.stamp_jump_threshold,
            on_jump=self._on_clock_jump,
        )
        message_type = TwistStamped if config.simulation else Twist
        self._publisher = self.create_lifecycle_publisher(message_type, "cmd_vel", 10)
        self._status_publisher = self.create_lifecycle_publisher(WallFollowerStatus, "~/status", 10)
        self._inputs = [
            self.create_subscription(
                Odometry, "odometry", lambda m: self._on_message(ODOMETRY, m), reliable(config.sync_queue_size)
            ),
            self.create_subscription(LaserScan, "scan", lambda m: self._on_message(SCAN, m), SENSOR_DATA),
        ]
        if config.navigated:
            self._inputs.append(
                self.create_subscription(
                    NavigatorStatus, NAVIGATOR_STATUS_TOPIC, self._on_navigator_status, reliable(config.sync_queue_size)
                )
            )
        self.get_logger().info(
            f"configured: {'simulation (lockstep, TwistStamped)' if config.simulation else 'real robot (timer, Twist)'}"
            f", following the {config.preferred_wall} wall at {config.target_wall_distance} m"
            + (", when the navigator says so" if config.navigated else "")
        )
        return TransitionCallbackReturn.SUCCESS

    def apply_live(self, changes: dict) -> None:
        """A tunable set while configured: the whole new configuration is checked, then used from the next scan."""
        config = WallFollowerConfig.from_params({**self.config.as_params(), **changes})
        self.config = config
        self.controller.reconfigure(config)

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self.controller.reset()
        self._sync.reset()
        return super().on_activate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._inputs, self._status_publisher = [], None
        self.config = self.controller = self._sync = None
        return super().on_cleanup(state)  # destroys what configure made

    # -- data flow ------------------------------------------------------------------------------

    def _on_message(self, index: int, message) -> None:
        self.feed_synchronizer(self._sync, index, message, self.warn_throttled)

    def _on_clock_jump(self, index: int, jump_ns: int) -> None:
        """Stamps went back (a simulator reset, or normal stamps after a bad one): start afresh from here."""
        self.get_logger().warning(
            f"{('/odometry', '/scan', '/navigator/status')[index]} stamps jumped by {jump_ns * 1e-9:+.3f} s: "
            "synchronizer and controller restarted"
        )
        self.controller.reset()
        self._latest = None

    def _on_pair(self, odometry: Odometry, scan: LaserScan) -> None:
        self._answer(odometry, scan)

    def _drives(self) -> bool:
        return not self.config.navigated or self._gate.in_charge

    def _on_navigator_status(self, message: NavigatorStatus) -> None:
        """A new decision for an observation held here is answered at once; any other status is paired."""
        if self.state_label != "active":
            return
        self._gate.route(message, self._on_held_pair, lambda status: self._on_message(STATUS, status))

    def _on_held_pair(self, odometry: Odometry, scan: LaserScan) -> None:
        self.get_logger().info("the navigator gave this node the held observation")
        self._on_pair(odometry, scan)

    def _on_navigated_triple(self, odometry: Odometry, scan: LaserScan, status: NavigatorStatus) -> None:
        """Answer the observation if the navigator gave it to this node (ControllerNode._admit)."""
        if self._admit(status, (odometry, scan)):
            self._on_pair(odometry, scan)

    def _compute(self, odometry: Odometry, scan: LaserScan) -> None:
        try:
            twist = odometry.twist.twist
            stamp = Time.from_msg(scan.header.stamp).nanoseconds * 1e-9
            command = self.controller.compute(scan_data(scan), twist.linear.x, twist.angular.z, stamp)
        except Exception as error:  # a controller bug must not take the robot's node down
            self.get_logger().error(f"controller failed, stopping: {error!r}", throttle_duration_sec=WARNING_PERIOD)
            command = Command(0.0, 0.0)
        if not command.ok:
            self.warn_throttled(command.describe())
        self.last_command = command
        self._publish(command.v, command.w)
        self._publish_status(scan, command)

    def _publish_status(self, scan: LaserScan, command: Command) -> None:
        seen = self.controller.measurements
        status = WallFollowerStatus(
            state=self.controller.state,
            followed_wall=seen.followed_wall,
            front=seen.front,
            left=seen.left,
            right=seen.right,
            wall_distance=seen.wall_distance,
            target_wall_distance=self.config.target_wall_distance,
            linear=command.v,
            angular=command.w,
            issues=[issue.value for issue in command.issues],
        )
        status.header.stamp = self.get_clock().now().to_msg()
        status.header.frame_id = "base_footprint"
        self._status_publisher.publish(status)


def main(args=None) -> None:
    run(WallFollowerNode, args=args)


if __name__ == "__main__":
    main()
