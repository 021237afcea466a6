"""log_player: a CARMEN laser log published as a robot would (`amr-play-log --ros-args -p log:=<file>`).

A thin shell over amr_datasets.player.LogPlayer:

configure  reads the log (`log`: plain or gzip CARMEN; a missing file or a malformed line fails, naming the file
           and the line), synthesizes the odometry (noise_*, seed) of the slice (start, count) and creates the
           topics.
activate   publishes base_footprint -> laser (identity: the log's poses are the laser's) on /tf_static, `playing`
           on ~/status, and the first scan; then goes on (a re-activation resumes where it stopped).

Each scan is one step, all stamped with its (log) time, in this order: /clock, odom -> base_footprint on /tf,
odometry (nav_msgs/Odometry odom -> base_footprint: the synthesized odometry, with the twist since the previous
scan), ground_truth (nav_msgs/Odometry in map: the corrected pose, the reference), scan (sensor_msgs/LaserScan,
frame laser, sensor-data QoS; +inf: no return).

mode lockstep (default): the next scan goes out when the consumer has answered the last one: a message on
`pace_topic` (`pace_type`, by default amr_interfaces/msg/LocalizedPose on `pose`, as the particle filter
publishes; amr_interfaces/msg/PoseGraph for a SLAM node) whose header stamp is at least the last scan's. After
`pace_timeout` wall seconds without one it warns, naming the topic, and goes on: a missing consumer slows it,
never hangs it.
mode realtime: each scan at its own stamp, `rate` log seconds per wall second; /clock ticks every 10 ms of wall
time in between.

When the slice ends (and `loop` is false) ~/status (std_msgs/String, latched) says `done`, and the node stays as it
is: active, the last transforms and messages standing. Stamps of 0 or less are moved so that the first is 1 s.
"""

from __future__ import annotations

import importlib
import time

from builtin_interfaces.msg import Time
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from rclpy.clock import Clock as RclpyClock
from rclpy.clock import ClockType
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.lifecycle import State, TransitionCallbackReturn
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from amr_datasets.carmen import SCAN_TYPES, DatasetError, read_carmen
from amr_datasets.odometry import OdometryNoiseModel
from amr_datasets.player import LogPlayer, PlayerStep
from amr_interfaces.msg import LocalizedPose
from amr_util.geometry import Pose2D, quaternion_from_yaw
from amr_util.managed_node import ManagedNode, run, topic_name_problem
from amr_util.parameter_spec import ParameterSpec
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_util.stamps import stamp_from_seconds, stamp_nanoseconds
from amr_util.throttle import Throttle
from amr_util.wire import WireMessage

TICK = 0.01
"""Wall s between realtime ticks (/clock, scans due)."""
WARNING_PERIOD = 5.0
"""Wall s between repeats of the pace timeout warning."""
TF_DEPTH = 100
DEFAULT_NOISE = OdometryNoiseModel()
ORIGIN = Pose2D(0.0, 0.0, 0.0)
DEFAULT_PACE_TYPE = "amr_interfaces/msg/LocalizedPose"
"""What the particle filter answers each scan with."""
QUIET_PUBLISHER = PublisherEventCallbacks(use_default_callbacks=False)
"""Publishers without rclpy's default QoS-event handlers: each is a waitable the executor checks at every wait
(as in the simulator node); a QoS mismatch is still reported by the subscriber's own handler."""


def pace_type_problem(name: str) -> str | None:
    """Why `name` (package/msg/Type or package/Type) is not a message type with a header, or None."""
    try:
        pace_message_type(name)
    except ValueError as problem:
        return str(problem)
    return None


def pace_message_type(name: str):
    """The message class named `name` (package/msg/Type or package/Type), which must have a header."""
    if name in (DEFAULT_PACE_TYPE, "amr_interfaces/LocalizedPose"):
        return LocalizedPose
    parts = name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        parts = [parts[0], parts[2]]
    if len(parts) != 2 or not all(parts):
        raise ValueError(f"{name!r}: expected a message type as package/msg/Type")
    try:
        kind = getattr(importlib.import_module(f"{parts[0]}.msg"), parts[1])
    except (ImportError, AttributeError):
        raise ValueError(f"{name!r}: no such message type") from None
    if "header" not in kind.get_fields_and_field_types():
        raise ValueError(f"{name!r}: has no header (the pace message's stamp says which scan it answers)")
    return kind


PARAMETERS = (
    ParameterSpec("log", "", "path of the CARMEN log to play (plain text or gzip)"),
    ParameterSpec(
        "mode",
        "lockstep",
        "lockstep: each scan once the consumer answered the last; realtime: at the log's stamps",
        choices=("lockstep", "realtime"),
    ),
    ParameterSpec(
        "rate",
        1.0,
        "realtime: log seconds per wall second",
        minimum=0.0,
        exclusive_minimum=True,
        maximum=1e6,
        live=True,
    ),
    ParameterSpec("pace_topic", "pose", "lockstep: the consumer's answer to each scan", check=topic_name_problem),
    ParameterSpec(
        "pace_type",
        DEFAULT_PACE_TYPE,
        "lockstep: its type (with a header stamped with the scan's stamp), e.g. amr_interfaces/msg/PoseGraph",
        check=pace_type_problem,
    ),
    ParameterSpec(
        "pace_timeout",
        5.0,
        "lockstep: wall s to wait for the answer, then warn and go on",
        minimum=0.0,
        exclusive_minimum=True,
        maximum=3600.0,
        live=True,
    ),
    ParameterSpec("start", 0, "index of the first scan played", minimum=0),
    ParameterSpec("count", 0, "scans played (0: to the end of the log)", minimum=0),
    ParameterSpec(
        "loop", False, "start again after the last scan (the robot carried back to the first pose; stamps go on)"
    ),
    ParameterSpec("seed", 0, "of the synthesized odometry's noise", minimum=0),
    ParameterSpec(
        "noise_alpha1",
        DEFAULT_NOISE.alpha1,
        "odometry rotation noise per rotation (rad/rad, a standard deviation)",
        minimum=0.0,
        maximum=10.0,
    ),
    ParameterSpec(
        "noise_alpha2",
        DEFAULT_NOISE.alpha2,
        "odometry rotation noise per translation (rad/m)",
        minimum=0.0,
        maximum=10.0,
    ),
    ParameterSpec(
        "noise_alpha3",
        DEFAULT_NOISE.alpha3,
        "odometry translation noise per translation (m/m)",
        minimum=0.0,
        maximum=10.0,
    ),
    ParameterSpec(
        "noise_alpha4",
        DEFAULT_NOISE.alpha4,
        "odometry translation noise per rotation (m/rad)",
        minimum=0.0,
        maximum=10.0,
    ),
    ParameterSpec(
        "noise_scale_error",
        DEFAULT_NOISE.scale_error,
        "odometry distances are (1 + this) times the true ones",
        minimum=-0.5,
        maximum=0.5,
    ),
    ParameterSpec(
        "noise_heading_bias",
        DEFAULT_NOISE.heading_bias,
        "odometry heading drift, rad per metre driven (0.5 deg/m)",
        minimum=-1.0,
        maximum=1.0,
    ),
    ParameterSpec(
        "message",
        "",
        "the scan lines to read (empty: the first of FLASER, ROBOTLASER1, RLASER, ROBOTLASER2 the log has)",
        choices=("", *SCAN_TYPES),
    ),
    ParameterSpec("max_range", 0.0, "m: readings at or above it are no return (0: found in the log)", minimum=0.0),
    ParameterSpec("map_frame", "map", "frame of ground_truth"),
    ParameterSpec("odom_frame", "odom", "frame of the odometry"),
    ParameterSpec("base_frame", "base_footprint", "the robot's frame (child of odom)"),
    ParameterSpec("laser_frame", "laser", "frame of scan (at base_frame: the log's poses are the laser's)"),
    ParameterSpec("publish_clock", True, "publish the log's time on /clock"),
)

ODOMETRY_FIELDS = (
    "header.stamp.sec",
    "header.stamp.nanosec",
    "pose.pose.position.x",
    "pose.pose.position.y",
    "pose.pose.orientation.z",
    "pose.pose.orientation.w",
    "twist.twist.linear.x",
    "twist.twist.linear.y",
    "twist.twist.angular.z",
)
TF_FIELDS = tuple(
    f"transforms.0.{name}"
    for name in (
        "header.stamp.sec",
        "header.stamp.nanosec",
        "transform.translation.x",
        "transform.translation.y",
        "transform.rotation.z",
        "transform.rotation.w",
    )
)
SCAN_FIELDS = ("header.stamp.sec", "header.stamp.nanosec", "ranges")
CLOCK_FIELDS = ("clock.sec", "clock.nanosec")


def odometry_message(stamp: Time, frame: str, child: str) -> Odometry:
    message = Odometry()
    message.header.stamp, message.header.frame_id, message.child_frame_id = stamp, frame, child
    message.pose.pose.orientation.w = 1.0
    return message


def transform(stamp: Time, parent: str, child: str, pose: Pose2D = ORIGIN) -> TransformStamped:
    message = TransformStamped()
    message.header.stamp, message.header.frame_id, message.child_frame_id = stamp, parent, child
    message.transform.translation.x, message.transform.translation.y = pose.x, pose.y
    _, _, message.transform.rotation.z, message.transform.rotation.w = quaternion_from_yaw(pose.theta)
    return message


def laser_scan(stamp: Time, frame: str, step: PlayerStep) -> LaserScan:
    scan = step.scan
    message = LaserScan()
    message.header.stamp, message.header.frame_id = stamp, frame
    message.angle_min = float(scan.angle_min)
    message.angle_increment = float(scan.angle_increment)
    message.angle_max = float(scan.angle_min + (len(scan.ranges) - 1) * scan.angle_increment)
    message.range_min, message.range_max = float(scan.range_min), float(scan.range_max)
    message.ranges = [float(r) for r in scan.ranges]
    return message


class LogPlayerNode(ManagedNode):
    """Wires LogPlayer to topics, the pace subscription and the lifecycle; decides nothing about the log."""

    def __init__(self, **kwargs) -> None:
        super().__init__("log_player", **kwargs)
        self.declare_specs(PARAMETERS)
        self.player: LogPlayer | None = None
        self._values: dict = {}
        self._outputs: dict[str, object] = {}
        self._wires: dict[object, WireMessage] = {}
        self._pace = None
        self._timer = None
        self._steady = RclpyClock(clock_type=ClockType.STEADY_TIME)  # wall timers, whatever use_sim_time says
        self._next = 0
        """The index of the next step to publish."""
        self._awaiting: int | None = None
        """Lockstep: the stamp (ns) of the last scan, until an answer stamped at least that comes."""
        self.done = False
        self.timeouts = 0
        self.published = 0
        self._last_clock = 0.0
        self._anchor = (0.0, 0.0)
        """Realtime: (wall s, log s) that match."""
        self._started = 0.0
        self._timeout_warnings = Throttle(WARNING_PERIOD)  # wall time

    # -- lifecycle ------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if problems:
            return self.fail_configure(problems)
        values = self._values = self.parameter_values()
        if not values["log"]:
            return self.fail_configure(["log: give the path of a CARMEN log (-p log:=<file>)"])
        try:
            log = read_carmen(values["log"], message=values["message"] or None, max_range=values["max_range"] or None)
            noise = OdometryNoiseModel(
                *(values[f"noise_alpha{i}"] for i in range(1, 5)),
                values["noise_scale_error"],
                values["noise_heading_bias"],
            )
            self.player = LogPlayer(log, noise, values["seed"], values["start"], values["count"], values["loop"])
            pace_type = pace_message_type(values["pace_type"])
        except (DatasetError, ValueError) as error:
            return self.fail_configure([str(error)])
        self._create_interfaces(values, pace_type)
        self._next, self._awaiting, self.done, self.timeouts, self.published = 0, None, False, 0, 0
        scan = log.scans[0].scan
        self.get_logger().info(
            f"{log.path}: {len(self.player)} of {len(log)} {log.message} scans ({len(scan.ranges)} beams, max range "
            + (f"{log.max_range:g} m" if log.max_range is not None else "none found")
            + "), "
            + ("stamps from the log" if log.has_stamps else "no stamps")
            + (f" ({log.stamp_problem})" if log.stamp_problem else "")
            + f"; {values['mode']}"
        )
        return TransitionCallbackReturn.SUCCESS

    def _create_interfaces(self, values: dict, pace_type) -> None:
        qos = reliable()

        def create(kind, topic, profile):
            return self.create_lifecycle_publisher(kind, topic, profile, event_callbacks=QUIET_PUBLISHER)

        self._outputs = {
            "tf": create(TFMessage, "tf", reliable(TF_DEPTH)),
            "tf_static": create(TFMessage, "tf_static", LATCHED),
            "odometry": create(Odometry, "odometry", qos),
            "ground_truth": create(Odometry, "ground_truth", qos),
            "scan": create(LaserScan, "scan", SENSOR_DATA),
            "status": create(String, "~/status", LATCHED),
        }
        if values["publish_clock"]:
            self._outputs["clock"] = create(Clock, "/clock", qos)
        if values["mode"] == "lockstep":
            self._pace = self.create_subscription(pace_type, values["pace_topic"], self._on_pace, qos)

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        result = super().on_activate(state)
        values = self._values
        if self._next == 0 and not self.done:
            stamp = stamp_from_seconds(self.player.stamp(0))
            self._outputs["tf_static"].publish(
                TFMessage(transforms=[transform(stamp, values["base_frame"], values["laser_frame"])])
            )
            self._started = time.monotonic()
        self._outputs["status"].publish(String(data="done" if self.done else "playing"))
        if self.done:
            return result
        if values["mode"] == "lockstep":
            if self._awaiting is None:
                self._publish_next()
            self._start_timer(values["pace_timeout"], self._on_pace_timeout)
        else:
            self._anchor = (time.monotonic(), self.player.stamp(self._next) if self._next == 0 else self._last_clock)
            self._start_timer(TICK, self._on_tick)
            self._on_tick()
        return result

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._stop_timer()
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._stop_timer()
        if self._pace is not None:
            self.destroy_subscription(self._pace)
        for publisher in self._outputs.values():
            self.destroy_lifecycle_publisher(publisher)
        self._pace, self._outputs, self._wires, self.player = None, {}, {}, None
        return super().on_cleanup(state)  # and whatever else configure made

    def apply_live(self, changes: dict) -> None:
        self._values.update(changes)
        if self.state_label != "active" or self.done:
            return
        if "pace_timeout" in changes and self._values["mode"] == "lockstep":
            self._start_timer(changes["pace_timeout"], self._on_pace_timeout)
        if "rate" in changes and self._values["mode"] == "realtime":
            self._anchor = (time.monotonic(), self._last_clock)

    def _start_timer(self, period: float, callback) -> None:
        self._stop_timer()
        self._timer = self.create_timer(period, callback, clock=self._steady)

    def _stop_timer(self) -> None:
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None

    # -- pacing ---------------------------------------------------------------------------------

    def _on_pace(self, message) -> None:
        if self._awaiting is None or self.state_label != "active":
            return
        if stamp_nanoseconds(message.header.stamp) >= self._awaiting:
            self._advance()

    def _on_pace_timeout(self) -> None:
        if self._awaiting is None:
            return
        self.timeouts += 1
        if self._timeout_warnings():
            self.get_logger().warning(
                f"no {self._values['pace_type']} on {self._pace.topic_name} stamped at least "
                f"{self._awaiting * 1e-9:.3f} s within {self._values['pace_timeout']:g} s: going on "
                f"({self.timeouts} timeouts so far)"
            )
        self._advance()

    def _advance(self) -> None:
        self._awaiting = None
        if self.player.has(self._next):
            self._publish_next()
            if self._timer is not None:
                self._timer.reset()
        else:
            self._finish()

    def _on_tick(self) -> None:
        if self.done or self.state_label != "active":
            return
        wall0, log0 = self._anchor
        now = log0 + (time.monotonic() - wall0) * self._values["rate"]
        while self.player.has(self._next) and self.player.stamp(self._next) <= now:
            self._publish_next()
        if not self.player.has(self._next):
            self._finish()
        elif now > self._last_clock:
            self._publish_clock(now)

    def _finish(self) -> None:
        self.done = True
        self._stop_timer()
        self._outputs["status"].publish(String(data="done"))
        wall = time.monotonic() - self._started
        self.get_logger().info(
            f"done: {self.published} scans in {wall:.2f} s wall ({self.published / max(wall, 1e-9):.0f} scans/s)"
            + (f", {self.timeouts} pace timeouts" if self.timeouts else "")
        )

    # -- publishing -----------------------------------------------------------------------------

    def _wire(self, key, fields, build) -> WireMessage:
        wire = self._wires.get(key)
        if wire is None:
            wire = self._wires[key] = WireMessage(build(), fields)
        return wire

    def _publish_clock(self, seconds: float) -> None:
        self._last_clock = seconds
        if "clock" in self._outputs:
            stamp = stamp_from_seconds(seconds)
            wire = self._wire("clock", CLOCK_FIELDS, lambda: Clock(clock=stamp))
            self._outputs["clock"].publish(wire.fill(stamp.sec, stamp.nanosec))

    def _publish_next(self) -> None:
        step = self.player.step(self._next)
        self._next += 1
        self.published += 1
        values, outputs = self._values, self._outputs
        stamp = stamp_from_seconds(step.stamp)
        sec, nanosec = stamp.sec, stamp.nanosec
        self._publish_clock(step.stamp)
        odom, pose = step.odom, step.pose
        _, _, odom_z, odom_w = quaternion_from_yaw(odom.theta)
        _, _, pose_z, pose_w = quaternion_from_yaw(pose.theta)
        wire = self._wire(
            "tf",
            TF_FIELDS,
            lambda: TFMessage(transforms=[transform(stamp, values["odom_frame"], values["base_frame"])]),
        )
        outputs["tf"].publish(wire.fill(sec, nanosec, odom.x, odom.y, odom_z, odom_w))
        wire = self._wire(
            "odometry", ODOMETRY_FIELDS, lambda: odometry_message(stamp, values["odom_frame"], values["base_frame"])
        )
        outputs["odometry"].publish(wire.fill(sec, nanosec, odom.x, odom.y, odom_z, odom_w, *step.odom_twist))
        wire = self._wire(
            "ground_truth", ODOMETRY_FIELDS, lambda: odometry_message(stamp, values["map_frame"], values["base_frame"])
        )
        outputs["ground_truth"].publish(wire.fill(sec, nanosec, pose.x, pose.y, pose_z, pose_w, *step.pose_twist))
        scan = step.scan
        key = ("scan", len(scan.ranges), scan.angle_min, scan.angle_increment, scan.range_max)
        wire = self._wire(key, SCAN_FIELDS, lambda: laser_scan(stamp, values["laser_frame"], step))
        outputs["scan"].publish(wire.fill(sec, nanosec, scan.ranges))
        if values["mode"] == "lockstep":
            self._awaiting = stamp_nanoseconds(stamp)


def main(args=None) -> None:
    run(LogPlayerNode, args=args)


if __name__ == "__main__":
    main()
