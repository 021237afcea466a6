"""path_follower: pure pursuit on /path with the localized /pose and /scan, /cmd_vel out (thin shell).

In charge once active, with a path, and the pose localized; before that it publishes nothing (the
wall follower drives). Simulation (`simulation: true`, lockstep): /pose and /scan of one step are
paired by stamp and each pair is answered with exactly one command, TwistStamped. The observation
that came last before it took charge is answered on taking charge, unless another node's /cmd_vel
answered it already (in lockstep nothing else would advance the simulator). Real robot
(`simulation: false`): a timer computes every dt from the latest pair and publishes Twist (the last
command between pairs), zero when no pair came for `stale_timeout`. When the follower asks for a new plan (blocked, strayed) the node calls the
planner's ~/plan service from the current pose to the path's end, once at a time, and follows the
answer. Bad messages are refused with a throttled warning; nothing raises out of a callback.
"""

from __future__ import annotations

from amr_interfaces.msg import LocalizedPose
from amr_interfaces.srv import PlanPath
from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Path
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.time import Time
from sensor_msgs.msg import LaserScan

from amr_control.path_follower import FollowCommand, PathError, PathFollower
from amr_control.path_follower_config import NODE_NAME, ConfigError, PathFollowerConfig
from amr_util.geometry import yaw_from_quaternion
from amr_util.managed_node import ManagedNode, run
from amr_util.messages import scan_data, velocity_command
from amr_util.qos import LATCHED, SENSOR_DATA
from amr_util.sync import ApproximateTimeSynchronizer

POSE, SCAN = 0, 1
WARNING_PERIOD = 2.0
SYNC_SLOP = 0.02  # s: /pose and /scan of one lockstep step carry the same stamp


class PathFollowerNode(ManagedNode):
    """Wires PathFollower to /path, /pose, /scan and /cmd_vel; holds no control logic."""

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(PathFollowerConfig.parameter_specs())
        self.config: PathFollowerConfig | None = None
        self.follower: PathFollower | None = None
        self.last_command: FollowCommand | None = None
        self.commands_sent = 0
        self._sync: ApproximateTimeSynchronizer | None = None
        self._entities: list = []
        self._publisher = None
        self._timer = None
        self._client = None
        self._replanning = False
        self._latest_pair = None
        self._latest_pair_time: Time | None = None
        self._unanswered = None  # the last localized pair seen before taking charge, if nobody answered it
        self.configure_error = ""

    # -- lifecycle ------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if not problems:
            try:
                config = PathFollowerConfig.from_params(self.parameter_values())
            except ConfigError as error:
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            return self.fail_configure(problems)
        self.config, self.follower = config, PathFollower(config)
        self._sync = ApproximateTimeSynchronizer(2, SYNC_SLOP, 10, self._on_pair)
        twist_type = TwistStamped if config.simulation else Twist
        self._publisher = self.create_lifecycle_publisher(twist_type, "cmd_vel", 10)
        self._entities = [
            self.create_subscription(twist_type, "cmd_vel", self._on_other_command, 10),
            self.create_subscription(Path, "path", self._on_path, LATCHED),
            self.create_subscription(LocalizedPose, "pose", lambda m: self._on_message(POSE, m), 10),
            self.create_subscription(LaserScan, "scan", lambda m: self._on_message(SCAN, m), SENSOR_DATA),
        ]
        self._client = self.create_client(PlanPath, config.planner_service)
        return TransitionCallbackReturn.SUCCESS

    def apply_live(self, changes: dict) -> None:
        """A tunable set while configured: the whole new configuration is checked, then used from the next pair."""
        try:
            config = PathFollowerConfig.from_params({**self.config.as_params(), **changes})
        except ConfigError as error:
            raise ValueError(str(error)) from error
        self.config = config
        self.follower.reconfigure(config)

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._sync.reset()
        if not self.config.simulation:
            self._timer = self.create_timer(self.config.dt, self._on_timer)
        return super().on_activate(state)

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        if self.in_charge:
            self._publish(0.0, 0.0)
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        for subscription in self._entities:
            self.destroy_subscription(subscription)
        self.destroy_client(self._client)
        self.destroy_lifecycle_publisher(self._publisher)
        self._entities, self._publisher, self._client = [], None, None
        self.config = self.follower = self._sync = None
        return TransitionCallbackReturn.SUCCESS

    @property
    def in_charge(self) -> bool:
        """Active with a path: the follower, not the wall follower, drives."""
        return self.state_label == "active" and self.follower is not None and self.follower.has_path

    # -- inputs -----------------------------------------------------------------------------------

    def _on_path(self, message: Path) -> None:
        if self.follower is None:
            return
        points = [(p.pose.position.x, p.pose.position.y) for p in message.poses]
        try:
            self.follower.set_path(points)
        except PathError as error:
            self.follower.clear()
            self._warn(f"/path refused, stopping: {error}")
            return
        self.get_logger().info(f"following a path of {len(points)} points")
        if self._unanswered is not None and self.in_charge and self.config.simulation:
            pair, self._unanswered = self._unanswered, None
            self._compute(*pair)

    def _on_other_command(self, message) -> None:
        if not self.in_charge:
            self._unanswered = None  # another controller answered the last observation

    def _on_message(self, index: int, message) -> None:
        if self.state_label != "active":
            return
        stamp = Time.from_msg(message.header.stamp).nanoseconds
        if stamp < 0:
            self._warn("a message with a negative stamp was dropped")
            return
        self._sync.add(index, stamp, message)

    def _on_pair(self, pose: LocalizedPose, scan: LaserScan) -> None:
        if not pose.localized:
            return
        if not self.in_charge:  # the wall follower answers this observation, or else the first one in charge will
            self._unanswered = (pose, scan)
            return
        self._unanswered = None
        if self.config.simulation:
            self._compute(pose, scan)
        else:
            self._latest_pair = (pose, scan)
            self._latest_pair_time = self.get_clock().now()

    def _on_timer(self) -> None:
        if not self.in_charge or self._latest_pair_time is None:
            return
        age = (self.get_clock().now() - self._latest_pair_time).nanoseconds * 1e-9
        if age > self.config.stale_timeout:
            self._warn(f"no localized /pose + /scan for {self.config.stale_timeout} s: stopping")
            self._publish(0.0, 0.0)
            return
        if self._latest_pair is None:  # the sensors are slower than dt: hold the last command
            last = self.last_command
            self._publish(last.v, last.w) if last is not None else self._publish(0.0, 0.0)
            return
        pair, self._latest_pair = self._latest_pair, None
        self._compute(*pair)

    def _compute(self, pose: LocalizedPose, scan: LaserScan) -> None:
        try:
            p = pose.pose.pose
            command = self.follower.compute(p.position.x, p.position.y, yaw_from_quaternion(p.orientation), scan_data(scan))
        except Exception as error:  # a controller bug must not take the robot's node down
            self.get_logger().error(f"path follower failed, stopping: {error!r}", throttle_duration_sec=WARNING_PERIOD)
            command = None
        if command is None:
            self._publish(0.0, 0.0)
            return
        if command.message and not command.reached:
            self._warn(command.message)
        if command.reached and (self.last_command is None or not self.last_command.reached):
            self.get_logger().info("goal reached")
        if command.replan:
            self._request_plan(pose)
        self.last_command = command
        self._publish(command.v, command.w)

    def _request_plan(self, pose: LocalizedPose) -> None:
        """Ask the planner for a path from here to the current path's end (one request at a time)."""
        if self._replanning or not self._client.service_is_ready():
            return
        goal = self.follower.goal
        request = PlanPath.Request()
        request.start.header = pose.header
        request.start.pose = pose.pose.pose
        request.goal.header = pose.header
        request.goal.pose.position.x, request.goal.pose.position.y = float(goal[0]), float(goal[1])
        self._replanning = True
        self._client.call_async(request).add_done_callback(self._on_plan)

    def _on_plan(self, future) -> None:
        self._replanning = False
        try:
            response = future.result()
        except Exception as error:
            self._warn(f"replanning failed: {error!r}")
            return
        if self.follower is None or not response.success:
            self._warn(f"replanning failed: {getattr(response, 'message', '')}")
            return
        self._on_path(response.path)

    # -- output -----------------------------------------------------------------------------------

    def _publish(self, v: float, w: float) -> None:
        if self._publisher is None:
            return
        self._publisher.publish(velocity_command(
            v, w, stamped=self.config.simulation, flip_angular_sign=self.config.flip_angular_sign,
            stamp=self.get_clock().now().to_msg()))
        self.commands_sent += 1

    def _warn(self, text: str) -> None:
        self.get_logger().warning(text, throttle_duration_sec=WARNING_PERIOD)


def main(args=None) -> None:
    run(PathFollowerNode, args=args)


if __name__ == "__main__":
    main()
