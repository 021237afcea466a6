"""path_follower: pure pursuit on a path with the localized /pose and /scan, /cmd_vel out (thin shell).

Alone (`navigated: false`): it follows the latest /path (nav_msgs/Path, transient local) and answers
every localized /pose + /scan pair once it has one. Under a navigator (`navigated: true`, the
`maze_navigation` stack): the navigator's navigator/status is a third synchronized input and the node
answers only the observations it gives this node (amr_control.navigated); the path comes from the
navigator through ~/follow_path (amr_interfaces/FollowPath, answered only while active), so it is in
place before the first observation that needs it.

Simulation (`simulation: true`, lockstep): each answered observation gets exactly one command,
TwistStamped. Real robot (`simulation: false`): a timer computes every dt from the latest pair and
publishes Twist (the last command between pairs), zero when no pair came for `stale_timeout`, and one
zero when the node stops being in charge (in simulation with `stepping: realtime`, one when the navigator gives
the robot to nobody). Every computed command is reported on ~/status
(amr_interfaces/PathFollowerStatus: state, reached, replan); a request for a new plan (blocked,
strayed) is only reported there, for the navigator to act on. Deactivation and shutdown send a zero
command. Bad messages are refused with a throttled warning; nothing raises out of a callback.

Speed limit: the latest amr_interfaces/SpeedLimit on `speed_limit` (the navigator's traffic rules, one per
observation it gives the path follower, stamped with that observation) caps the forward speed of the
observations stamped at most `speed_limit_timeout` after it (PathFollower.compute's speed_limit: 0 = stand,
WAITING, in-place turns go on); an older limit has expired: uncapped. The limit for an observation is published
before the navigator's status that names this node for it.

An observation the navigator gives this node although the localizer was unsure of it (a robot on a fleet plan,
amr_navigation's coordination plan) is driven from the pose in the navigator's status: its dead reckoning.
"""

from __future__ import annotations

import math

from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Path
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.time import Time
from sensor_msgs.msg import LaserScan

from amr_control.controller_node import ControllerNode
from amr_control.navigated import NAVIGATOR_STATUS_TOPIC
from amr_control.path_follower import FollowCommand, PathError, PathFollower
from amr_control.path_follower_config import NODE_NAME, ConfigError, PathFollowerConfig
from amr_interfaces.msg import LocalizedPose, NavigatorStatus, PathFollowerStatus, SpeedLimit
from amr_interfaces.srv import FollowPath
from amr_util.geometry import yaw_from_quaternion
from amr_util.managed_node import WARNING_PERIOD, run
from amr_util.messages import scan_data
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_util.sync import ApproximateTimeSynchronizer, SyncError, checked_stamp
from amr_util.throttle import ThrottledLogger

POSE, SCAN, STATUS = 0, 1, 2
SYNC_SLOP = 0.02  # s: /pose, /scan (and the navigator's status) of one lockstep step carry the same stamp


def driven_pose(pose: LocalizedPose, status: NavigatorStatus) -> LocalizedPose:
    """The pose to drive by for an observation the navigator gave this node: the /pose, or, when the localizer was
    unsure of it, the pose the navigator decided on (its status's: a robot on a fleet plan goes on by odometry from
    its last sure estimate; no other navigator mode names the path follower for an unsure /pose)."""
    if pose.localized:
        return pose
    driven = LocalizedPose(header=pose.header, localized=False)
    driven.pose.pose = status.pose
    return driven


def ends_at_goal(path_end, goal: tuple[float, float] | None, tolerance: float) -> bool:
    """Whether the end of the path followed is the goal: a path's end is logged as "goal reached" only then.

    `goal` is the navigator's (its latest status's; None alone or while it has named none: the path is the goal).
    A fleet route is handed over in legs, each ending at a waypoint; only the last one ends at the goal.
    """
    if goal is None or path_end is None:
        return True
    return math.hypot(float(path_end[0]) - goal[0], float(path_end[1]) - goal[1]) <= tolerance


class PathFollowerNode(ControllerNode):
    """Wires PathFollower to its path, /pose, /scan and /cmd_vel (amr_control.controller_node: the observations
    answered, the timer, the navigator's charge, the command); holds no control logic."""

    INPUTS = "localized /pose + /scan"

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(PathFollowerConfig.parameter_specs())
        self.config: PathFollowerConfig | None = None
        self.follower: PathFollower | None = None
        self.last_command: FollowCommand | None = None
        self._sync: ApproximateTimeSynchronizer | None = None
        self._entities: list = []
        self._status_publisher = None
        self._throttled = ThrottledLogger(lambda: self.get_logger(), WARNING_PERIOD)
        """errors a node may repeat every step, decided before rclpy's logger resolves its caller."""
        self._speed_limit: tuple[int, float | None] | None = None  # (stamp ns, m/s or None)
        self._navigator_goal: tuple[float, float] | None = None  # the latest navigator status's goal
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
        inputs, callback = (3, self._on_navigated_triple) if config.navigated else (2, self._on_pair)
        self._sync = ApproximateTimeSynchronizer(inputs, SYNC_SLOP, 10, callback)
        twist_type = TwistStamped if config.simulation else Twist
        self._publisher = self.create_lifecycle_publisher(twist_type, "cmd_vel", 10)
        self._status_publisher = self.create_lifecycle_publisher(PathFollowerStatus, "~/status", reliable())
        self._entities = [
            self.create_subscription(LocalizedPose, "pose", lambda m: self._on_message(POSE, m), 10),
            self.create_subscription(LaserScan, "scan", lambda m: self._on_message(SCAN, m), SENSOR_DATA),
            self.create_active_service(FollowPath, "~/follow_path", self._on_follow_path),
            self.create_subscription(SpeedLimit, "speed_limit", self._on_speed_limit, reliable()),
        ]
        if config.navigated:
            self._entities.append(
                self.create_subscription(NavigatorStatus, NAVIGATOR_STATUS_TOPIC, self._on_navigator_status, reliable())
            )
        else:
            self._entities.append(self.create_subscription(Path, "path", self._on_path, LATCHED))
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
        self._speed_limit = None
        self._navigator_goal = None
        return super().on_activate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._entities, self._status_publisher = [], None
        self.config = self.follower = self._sync = None
        return super().on_cleanup(state)  # destroys what configure made

    @property
    def in_charge(self) -> bool:
        """Active with a path and, under a navigator, named by its latest status: this node drives."""
        if self.state_label != "active" or self.follower is None or not self.follower.has_path:
            return False
        return self._gate.in_charge if self.config.navigated else True

    def _drives(self) -> bool:
        return self.in_charge

    # -- the path ---------------------------------------------------------------------------------

    def _take_path(self, message: Path) -> str:
        """Follow the path of `message`; '' or why it was refused (the follower then has none)."""
        points = [(p.pose.position.x, p.pose.position.y) for p in message.poses]
        try:
            self.follower.set_path(points)
        except PathError as error:
            self.follower.clear()
            return str(error)
        self.get_logger().info(f"following a path of {len(points)} points")
        return ""

    def _on_path(self, message: Path) -> None:
        if self.follower is None:
            return
        problem = self._take_path(message)
        if problem:
            self.warn_throttled(f"/path refused, stopping: {problem}")

    def _on_follow_path(self, request: FollowPath.Request, response: FollowPath.Response) -> FollowPath.Response:
        try:
            problem = self._take_path(request.path)
        except Exception as error:  # nothing raises out of a callback
            problem = f"{type(error).__name__}: {error}"
        response.success, response.message = not problem, problem or f"following {len(request.path.poses)} points"
        return response

    # -- inputs -----------------------------------------------------------------------------------

    def _on_message(self, index: int, message) -> None:
        self.feed_synchronizer(self._sync, index, message, self.warn_throttled)

    def _on_speed_limit(self, message: SpeedLimit) -> None:
        if self.state_label != "active":
            return
        try:
            stamp = checked_stamp(message)
        except SyncError as error:  # the limit before it stands
            self.warn_throttled(f"speed limit: {error}")
            return
        speed = float(message.speed)
        if message.limited and not (math.isfinite(speed) and speed >= 0.0):
            self.warn_throttled(f"a speed limit of {speed!r} m/s was taken as a stop")
            speed = 0.0
        self._speed_limit = (stamp, speed if message.limited else None)

    def speed_limit_for(self, stamp: int) -> float | None:
        """The cap (m/s) for the observation of `stamp` (ns): the latest limit unless it has expired."""
        if self._speed_limit is None:
            return None
        limit_stamp, speed = self._speed_limit
        if (stamp - limit_stamp) * 1e-9 > self.config.speed_limit_timeout:
            return None
        return speed

    def _on_navigator_status(self, message: NavigatorStatus) -> None:
        """A new decision for an observation held here is answered at once; any other status is paired."""
        if self.state_label != "active":
            return
        self._navigator_goal = (message.goal.x, message.goal.y) if message.has_goal else None
        self._gate.route(
            message,
            lambda pose, scan: self._answer(driven_pose(pose, message), scan),
            lambda status: self._on_message(STATUS, status),
        )

    def _on_navigated_triple(self, pose: LocalizedPose, scan: LaserScan, status: NavigatorStatus) -> None:
        if self._admit(status, (pose, scan)):
            self._answer(driven_pose(pose, status), scan)

    def _on_pair(self, pose: LocalizedPose, scan: LaserScan) -> None:
        if pose.localized and self.in_charge:
            self._answer(pose, scan)

    def _compute(self, pose: LocalizedPose, scan: LaserScan) -> None:
        try:
            p = pose.pose.pose
            limit = self.speed_limit_for(Time.from_msg(pose.header.stamp).nanoseconds)
            command = self.follower.compute(
                p.position.x, p.position.y, yaw_from_quaternion(p.orientation), scan_data(scan), speed_limit=limit
            )
        except Exception as error:  # a controller bug must not take the robot's node down
            self._throttled.error(f"path follower failed, stopping: {error!r}")
            command = None
        if command is None:
            self._publish(0.0, 0.0)
            return
        if command.message and not command.reached:
            self.warn_throttled(command.message)
        if command.reached and (self.last_command is None or not self.last_command.reached):
            if ends_at_goal(self.follower.goal, self._navigator_goal, self.config.goal_tolerance):
                self.get_logger().info("goal reached")
            else:  # a leg of a fleet route: the navigator hands over the next
                self.get_logger().debug("end of the path reached (a leg of the route, not the goal)")
        self.last_command = command
        self._publish(command.v, command.w)
        self._publish_status(scan, command)

    # -- output -----------------------------------------------------------------------------------

    def _publish_status(self, scan: LaserScan, command: FollowCommand) -> None:
        status = PathFollowerStatus(
            state=command.state.value,
            reached=command.reached,
            replan=command.replan,
            cross_track=float(command.cross_track),
            remaining=float(command.remaining),
            linear=float(command.v),
            angular=float(command.w),
            message=command.message,
        )
        status.header.stamp = scan.header.stamp
        status.header.frame_id = "map"
        self._status_publisher.publish(status)


def main(args=None) -> None:
    run(PathFollowerNode, args=args)


if __name__ == "__main__":
    main()
