"""simulator: the amr_simulation library as a lifecycle node (`ros2 run amr_simulation simulator`).

configure  reads the parameters, loads and validates the world and builds the simulator, its
           topics and services; a bad parameter or world fails with a message naming the key
           and leaves nothing behind (the node stays unconfigured).
activate   starts: publishes one observation (so a lockstep loop can begin), then steps.
deactivate stops: no more steps, the held command is zeroed.
cleanup    frees the simulator, topics and services.

mode lockstep: every /cmd_vel advances exactly one dt and is answered by exactly one
observation; a non-finite command is refused with a warning but still advances one dt at
zero velocity, so that the loop never deadlocks.
mode realtime: a wall-clock timer every dt / rate seconds steps with the latest command and
publishes /clock first; a command older than command_timeout simulated seconds stops the
robot (0 disables); a non-finite command is ignored (the previous one keeps running).

An observation is, in this order, all stamped with the simulated time: /clock, /tf (odom ->
base_footprint, and map -> odom with publish_map_to_odom), odometry, odom, ground_truth, scan,
~/status (each unless its publish_* parameter is false). /clock goes out in both modes, so every
node of a simulated stack can run on use_sim_time; /tf_static (base_footprint -> base_scan, the
LiDAR mounting) is published once, latched, at activation.
Activation, ~/reset and ~/set_pose each publish one observation too (a new starting point).

Watching a run: ~/pause holds the loop (lockstep: the /cmd_vel that answers the last
observation is kept, not stepped; realtime: the timer steps no more), ~/resume lets it go on (the
held command steps at once), ~/step advances exactly one step and stays paused (pausing first if
running; in lockstep with no command held yet, the next /cmd_vel is stepped when it comes, or, when none
has come for lockstep_resend_period, a step at zero velocity is taken: the driver holds the robot, as
a navigator with nobody_drives: wait does while nobody drives). While paused no observation is resent: /clock
stops exactly. A paused and stepped lockstep run is the run it would have been: every command still advances one
dt, in order. The live parameter `pace` sets the speed: lockstep 0 steps each command at once, N > 0 holds
each command until a steady timer at dt / N releases it (at most N x real time); realtime N > 0
replaces `rate`. ~/reset and ~/set_pose drop a held command (it answered the old observation).
Stamps never go back: a reset restarts the simulator's own time (status sim_time), while the
stamps carry on one dt after the last one, so stamp-ordered consumers keep working.

Several robots (docs/fleet.md): a world with a `robots` list runs them all here, each robot's topics
and services in its namespace (<name>/cmd_vel, <name>/scan, <name>/status, <name>/tf, <name>/set_pose,
<name>/reset, ...; with one_tf_tree the shared /tf with prefixed frames). Lockstep advances the world when every
robot has a command held, then every robot's observation goes out; the resend timer republishes only to the
robots that have not answered, and a step owed while paused takes zero velocity for those. Realtime steps every
robot with its latest command (each one's own command_timeout). ~/reset, ~/pause, ~/resume, ~/step, ~/render act
on the world. A world without `robots` is the node described above, topic for topic.

Localization: a world that declares `beacons` adds /beacons (amr_interfaces/BeaconRanges:
noisy range to each beacon in the world's order, and a noisy compass) to every observation. With
`enable_localization` the node listens to /pose (a localizer's LocalizedPose), compares each estimate
with the true pose at its stamp, logs once when the robot is first localized ("localized at t = ...,
error x m, y deg") and reports the latest error in ~/status. With `lockstep_pose_wait` > 0 as well, lockstep
takes the localizer into the loop: a step waits, besides every /cmd_vel, for the /pose stamped with the last
observation (each robot's own), at most that many wall-clock seconds (then it steps without it and says so); an
observation sent again whose /pose came is not waited for again (a localizer drops the repeated stamp).
A localizer outside the loop falls behind when the loop runs faster than it, and drops observations.
"""

from __future__ import annotations

from pathlib import Path

from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.clock import Clock as RclpyClock
from rclpy.clock import ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.lifecycle import State, TransitionCallbackReturn
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

from amr_interfaces.msg import BeaconRanges, LocalizedPose, SimulatorStatus
from amr_interfaces.srv import SetPose
from amr_maps.world import load_world, resolve_world_path, world_problem
from amr_simulation import messages
from amr_simulation.config import SimulationConfig
from amr_simulation.fleet import Fleet
from amr_simulation.parameters import NODE_PARAMETERS, parameter_specs
from amr_simulation.simulator import Simulator
from amr_simulation.world_control import RobotTurn, WorldControl
from amr_util.geometry import Pose2D, quaternion_from_yaw, yaw_from_quaternion
from amr_util.managed_node import ManagedNode, run
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_util.stamps import stamp_from_seconds, stamp_nanoseconds
from amr_util.wire import WireMessage

TF_DEPTH = 100
"""Queue depth of /tf (tf2's dynamic broadcaster uses 100)."""
WARNING_PERIOD = 5.0
"""s between repeats of a throttled warning."""
QUIET_PUBLISHER = PublisherEventCallbacks(use_default_callbacks=False)
"""Event callbacks of the node's publishers: none (see SimulatorNode._publisher)."""
REPORTED = SubscriptionEventCallbacks()
"""rclpy's default QoS-event handlers, kept on a one-robot world's /cmd_vel and /pose (a ManagedNode on simulated
time has none): a controller of one's own with an incompatible QoS is reported here. A fleet's robots have none
(two waitables per robot and input in every wait of this node)."""


class RobotChannel:
    """One robot's side of the node: its topics, frames and serialized messages (its stepping: RobotTurn).

    The one robot of a world without `robots` has the topics the node always had (`scan`, `~/status`, `/tf`,
    ...); a robot of a fleet has them in its namespace (`<name>/scan`, `<name>/status`, `<name>/tf`, ...).
    """

    def __init__(self, index: int, name: str) -> None:
        self.index = index
        self.name = name
        self.prefix = f"{name}/" if name else ""
        """Of its topic and service names: relative, so `<name>/scan` is /<name>/scan in the root namespace."""
        self.label = f"{name}: " if name else ""
        """Of its log lines."""
        self.frames: dict[str, str] = {}
        self.outputs: dict[str, object] = {}
        self.tf = None
        """The publisher its transforms go out on (/tf shared, or <name>/tf)."""
        self.tf_static = None
        self.cmd_vel_subscription = None
        self.services: list = []
        self.localization_inputs: list = []
        self.wires: dict[object, WireMessage] = {}
        """Its outgoing messages by topic, serialized at the first observation and rewritten in place at each one
        after (amr_util.wire: converting a message for rclpy costs more than writing it)."""

    def wire(self, key, fields: tuple[str, ...], build) -> WireMessage:
        """The serialized message of `key`, built from `build()` the first time."""
        wire = self.wires.get(key)
        if wire is None:
            wire = self.wires[key] = WireMessage(build(), fields)
        return wire

    def topic(self, name: str) -> str:
        """Its topic `name`: a `~/` name of the one robot stays the node's, a fleet robot's is in its namespace."""
        if name.startswith("~/"):
            return f"{self.prefix}{name[2:]}" if self.name else name
        return f"{self.prefix}{name}"


class SimulatorNode(ManagedNode):
    """A thin shell: parameters in, the world's robots step (amr_simulation.world_control), messages out."""

    def __init__(self, **kwargs) -> None:
        super().__init__("simulator", **kwargs)
        self.declare_specs(parameter_specs(world_problem))
        self._control: WorldControl | None = None
        self._robots: list[RobotChannel] = []
        self._outputs: dict[str, object] = {}
        """World-wide publishers: /clock, and /tf and /tf_static when the robots share them."""
        self._node_services: list = []
        self._resend_timer = None
        self._tf_parts = (False, False)
        self._stamped = True
        self._pace_timer = None
        self._pose_wait_timer = None
        self._steady = RclpyClock(clock_type=ClockType.STEADY_TIME)  # timers immune to use_sim_time on this node

    @property
    def _sim(self) -> Simulator | Fleet | None:
        return self._control.sim if self._control is not None else None

    @property
    def _fleet(self) -> Fleet | None:
        return self._control.fleet if self._control is not None else None

    @property
    def robot_names(self) -> tuple[str, ...]:
        """The names of the robots it simulates (("",) for a world without `robots`); () before configure."""
        return tuple(channel.name for channel in self._robots)

    # -- lifecycle -------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if problems:
            return self.fail_configure(problems)
        try:
            self._control = WorldControl(
                self._build(self._library_parameters()),
                publish=self._publish_observation,
                logger=self.get_logger,
                judge_poses=self.get_parameter("enable_localization").value,
            )
            self._create_interfaces()
        except Exception as error:  # ValueErrors name the key; anything else is reported as is
            self._teardown()
            detail = str(error) if isinstance(error, ValueError) else f"{type(error).__name__}: {error}"
            self.get_logger().error(f"configure failed: {detail}")
            return TransitionCallbackReturn.FAILURE
        config = self._fleet.config
        robots = f", robots {', '.join(self.robot_names)}" if self._fleet.world.robots else ""
        self.get_logger().info(
            f"world {self._fleet.world.name} ({self._fleet.world.source}){robots}, mode {config.mode}, dt {config.dt} s"
            + (f", rate {config.rate}" if config.mode == "realtime" else "")
        )
        return TransitionCallbackReturn.SUCCESS

    @staticmethod
    def _build(params: dict) -> Simulator | Fleet:
        """A Simulator for a world of one unnamed robot (the node as it always was), a Fleet for a `robots` list."""
        config = SimulationConfig.from_params(params)
        world = load_world(resolve_world_path(config.world))
        return Fleet(world, config) if world.robots else Simulator(world, config)

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        result = super().on_activate(state)
        control = self._control
        resend = self.get_parameter("lockstep_resend_period").value
        localizing = self.get_parameter("enable_localization").value
        control.activate(
            resend_period=resend,
            pose_wait=self.get_parameter("lockstep_pose_wait").value if localizing else 0.0,
            scan_period=self.get_parameter("scan_period").value,
        )
        if control.lockstep and resend > 0.0:
            self._resend_timer = self.create_timer(resend, self._on_resend_timer, clock=self._steady)
        self._set_pace(self.get_parameter("pace").value)
        if control.pose_wait > 0.0:
            self._pose_wait_timer = self.create_timer(control.pose_wait / 2, self._release_late, clock=self._steady)
        self._publish_static_tf()
        self._publish_goals()
        control.observe(control.robots)
        return result

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._stop_timer()
        self.get_logger().info(self._control.deactivate())
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._teardown()
        return super().on_cleanup(state)  # and whatever else configure made

    def destroy_node(self) -> None:
        if self._control is not None:
            self._control.active = False
        self._teardown()
        super().destroy_node()

    # -- building --------------------------------------------------------------------------

    def _library_parameters(self) -> dict:
        """The parameters the amr_simulation library takes (all but the node's own)."""
        return {name: value for name, value in self.parameter_values().items() if name not in NODE_PARAMETERS}

    def apply_live(self, changes: dict) -> None:
        """Noise, slip, the command timeout or the pace while configured: checked as a whole, used from the next
        step."""
        if self._sim is None:
            return
        library = {name: value for name, value in changes.items() if name not in NODE_PARAMETERS}
        if library:
            self._sim.retune(SimulationConfig.from_params({**self._library_parameters(), **library}))
        if "pace" in changes and self._control.active:
            self._set_pace(changes["pace"])

    def _create_interfaces(self) -> None:
        def get(name: str):
            return self.get_parameter(name).value

        qos = reliable(get("qos_depth"))
        fleet = self._fleet
        named = bool(fleet.world.robots)
        shared_tf = not named or get("one_tf_tree")
        self._stamped = fleet.config.cmd_vel_stamped
        if get("publish_clock"):
            self._outputs["clock"] = self._publisher(Clock, "/clock", qos)
        self._tf_parts = (get("publish_tf"), get("publish_map_to_odom"))
        if shared_tf:
            self._create_tf_publishers(self._outputs, "/tf", "/tf_static")
        topics = {
            "odometry": (Odometry, qos),
            "odom": (Odometry, qos),
            "ground_truth": (Odometry, qos),
            "scan": (LaserScan, SENSOR_DATA),
            "status": (SimulatorStatus, qos),
        }
        plain = {name: get(f"{name}_frame") for name in ("odom", "world", "base", "scan")}
        for robot in fleet.robots:
            channel = RobotChannel(robot.index, robot.name)
            self._robots.append(channel)
            prefix = f"{robot.name}/" if named and shared_tf else ""
            channel.frames = {name: frame if name == "world" else prefix + frame for name, frame in plain.items()}
            for name, (kind, topic_qos) in topics.items():
                if get(f"publish_{name}"):
                    topic = channel.topic("~/status" if name == "status" else name)
                    channel.outputs[name] = self._publisher(kind, topic, topic_qos)
            if not shared_tf:
                self._create_tf_publishers(channel.outputs, channel.topic("tf"), channel.topic("tf_static"))
            outputs = self._outputs if shared_tf else channel.outputs
            channel.tf, channel.tf_static = outputs.get("tf"), outputs.get("tf_static")
            if robot.goal is not None:
                channel.outputs["goal"] = self._publisher(PoseStamped, channel.topic("~/goal"), LATCHED)
            channel.cmd_vel_subscription = self.create_subscription(
                TwistStamped if self._stamped else Twist,
                channel.topic("cmd_vel"),
                lambda message, channel=channel: self._on_cmd_vel(channel, message),
                qos,
                event_callbacks=None if channel.name else REPORTED,
            )
            if named:
                channel.services = [
                    self.create_active_service(
                        Trigger,
                        channel.topic("reset"),
                        lambda q, a, channel=channel: self._answer(
                            a, lambda: self._control.reset_robot(channel.index), channel.label + "reset failed: "
                        ),
                    ),
                    self.create_active_service(
                        SetPose,
                        channel.topic("set_pose"),
                        lambda q, a, channel=channel: self._on_set_pose(channel, q, a),
                    ),
                ]
            self._create_localization_interfaces(channel, qos)
        self._node_services = [
            self.create_active_service(Trigger, "~/reset", self._on_reset),
            self.create_active_service(Trigger, "~/render", self._on_render),
            self.create_active_service(Trigger, "~/pause", lambda q, a: self._on_control(a, self._control.pause)),
            self.create_active_service(Trigger, "~/resume", lambda q, a: self._on_control(a, self._control.resume)),
            self.create_active_service(Trigger, "~/step", lambda q, a: self._on_control(a, self._control.step_once)),
        ]
        if not named:
            self._node_services.append(
                self.create_active_service(SetPose, "~/set_pose", lambda q, a: self._on_set_pose(self._robots[0], q, a))
            )

    def _publisher(self, kind, topic: str, qos):
        """A lifecycle publisher without rclpy's default QoS-event handlers (incompatible QoS, incompatible type).

        Each handler is a waitable that the executor adds to its wait set and checks at every wait, and the node
        has six or more publishers per robot: with 5 robots the 74 handlers cost about a fifth of a lockstep step's
        CPU (docs/fleet.md). The mismatch they would log is logged by the subscriber's own default handler
        ("New publisher discovered on topic ..., offering incompatible QoS"), where the user is looking anyway;
        the cmd_vel and pose subscriptions keep theirs (a Twist sent to a TwistStamped cmd_vel is reported here)."""
        return self.create_lifecycle_publisher(kind, topic, qos, event_callbacks=QUIET_PUBLISHER)

    def _create_tf_publishers(self, outputs: dict, tf: str, tf_static: str) -> None:
        """tf (reliable, volatile) and tf_static (transient local: late joiners get the mounting)."""
        if self._tf_parts[0]:
            outputs["tf_static"] = self._publisher(TFMessage, tf_static, LATCHED)
        if any(self._tf_parts):
            outputs["tf"] = self._publisher(TFMessage, tf, reliable(TF_DEPTH))

    def _teardown(self) -> None:
        """Destroy whatever exists; safe on a half-built node."""
        self._stop_timer()
        for service in self._node_services:
            self.destroy_service(service)
        for channel in self._robots:
            for service in channel.services:
                self.destroy_service(service)
            for subscription in [channel.cmd_vel_subscription, *channel.localization_inputs]:
                if subscription is not None:
                    self.destroy_subscription(subscription)
            for publisher in channel.outputs.values():
                self.destroy_lifecycle_publisher(publisher)
        for publisher in self._outputs.values():
            self.destroy_lifecycle_publisher(publisher)
        self._node_services, self._robots, self._outputs, self._control = [], [], {}, None

    def _stop_timer(self) -> None:
        for timer in (self._resend_timer, self._pace_timer, self._pose_wait_timer):
            if timer is not None:
                self.destroy_timer(timer)
        self._resend_timer = self._pace_timer = self._pose_wait_timer = None
        if self._control is not None:
            self._control.forget_waits()

    def _set_pace(self, pace: float) -> None:
        """The steady timer that paces the steps (WorldControl.pace): lockstep, none for 0; realtime, the step
        timer itself."""
        if self._pace_timer is not None:
            self.destroy_timer(self._pace_timer)
            self._pace_timer = None
        period = self._control.pace(pace)
        if period is not None:
            tick = self._on_timer if not self._control.lockstep else self._on_pace_timer
            self._pace_timer = self.create_timer(period, tick, clock=self._steady)

    # -- messages and timers -> the world's stepping -----------------------------------------

    def _on_cmd_vel(self, channel: RobotChannel, message: TwistStamped | Twist) -> None:
        try:
            twist = message.twist if self._stamped else message
            self._control.command(channel.index, twist.linear.x, twist.angular.z)
        except Exception as error:
            self.get_logger().error(
                f"{channel.label}cmd_vel callback: {type(error).__name__}: {error}",
                throttle_duration_sec=WARNING_PERIOD,
            )

    def _release_late(self) -> None:
        try:
            self._control.release_late()
        except Exception as error:
            self.get_logger().error(
                f"pose wait timer: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD
            )

    def _on_pace_timer(self) -> None:
        try:
            self._control.pace_tick()
        except Exception as error:
            self.get_logger().error(
                f"pace timer: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD
            )

    def _on_timer(self) -> None:
        try:
            self._control.tick()
        except Exception as error:
            self.get_logger().error(
                f"step timer: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD
            )

    def _on_resend_timer(self) -> None:
        try:
            self._control.resend_tick()
        except Exception as error:
            self.get_logger().error(
                f"resend timer: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD
            )

    # -- observations -> messages --------------------------------------------------------------

    def _publish_observation(self, turns: list[RobotTurn], now: float, rate: float) -> None:
        """/clock, then each robot's transforms (one TFMessage per tf topic), then each robot's messages."""
        channels = [self._robots[turn.index] for turn in turns]
        stamp = stamp_from_seconds(now)
        if "clock" in self._outputs:
            self._outputs["clock"].publish(messages.clock(stamp))
        odom_to_base, map_to_odom_wanted = self._tf_parts
        if odom_to_base or map_to_odom_wanted:
            groups: dict[int, tuple[object, list]] = {}
            for channel in channels:
                if channel.tf is not None:
                    groups.setdefault(id(channel.tf), (channel.tf, []))[1].append(channel)
            for publisher, group in groups.values():
                publisher.publish(self._tf_wire(group, stamp))
        for turn, channel in zip(turns, channels, strict=True):
            self._publish_robot(turn, channel, stamp, rate)

    def _tf_wire(self, group: list[RobotChannel], stamp) -> bytes:
        """The TFMessage of these robots' transforms (messages.robot_transforms), serialized; kept by the first
        robot of the group for the next observation of the same group."""
        parts = [
            part
            for channel in group
            for part in messages.robot_transforms(self._fleet.robots[channel.index], channel.frames, *self._tf_parts)
        ]
        key = ("tf", tuple(channel.index for channel in group))
        wire = group[0].wires.get(key) or group[0].wire(
            key,
            tuple(f"transforms.{i}.{field}" for i in range(len(parts)) for field in messages.TRANSFORM_WIRE),
            lambda: messages.tf_message([messages.transform(stamp, *part) for part in parts]),
        )
        values = []
        for _, _, pose in parts:
            values += (stamp.sec, stamp.nanosec, pose.x, pose.y, *quaternion_from_yaw(pose.theta))
        return wire.fill(*values)

    def _publish_robot(self, turn: RobotTurn, channel: RobotChannel, stamp, rate: float) -> None:
        fleet, frames, outputs = self._fleet, channel.frames, channel.outputs
        robot = fleet.robots[channel.index]
        sec, nanosec = stamp.sec, stamp.nanosec
        odom = robot.odom_pose
        odom_rotation = quaternion_from_yaw(odom.theta)
        if "odometry" in outputs:
            v, w = robot.odom_twist
            wire = channel.wire(
                "odometry",
                messages.ODOMETRY_WIRE,
                lambda: messages.odometry(stamp, frames["odom"], frames["base"], odom, (v, 0.0, w)),
            )
            outputs["odometry"].publish(wire.fill(sec, nanosec, odom.x, odom.y, *odom_rotation, v, 0.0, w))
        if "odom" in outputs:
            wire = channel.wire(
                "odom",
                messages.ODOMETRY_WIRE,
                lambda: messages.odometry(stamp, frames["odom"], frames["base"], odom, (0.0, 0.0, 0.0)),
            )
            outputs["odom"].publish(wire.fill(sec, nanosec, odom.x, odom.y, *odom_rotation, 0.0, 0.0, 0.0))
        if "ground_truth" in outputs:
            pose, (vx, vy, w) = robot.pose, robot.twist
            wire = channel.wire(
                "ground_truth",
                messages.ODOMETRY_WIRE,
                lambda: messages.odometry(stamp, frames["world"], frames["base"], pose, (vx, vy, w)),
            )
            outputs["ground_truth"].publish(
                wire.fill(sec, nanosec, pose.x, pose.y, *quaternion_from_yaw(pose.theta), vx, vy, w)
            )
        if "scan" in outputs and self._control.scan_due():
            ranges = robot.ranges
            wire = channel.wire(
                ("scan", len(ranges)),
                messages.SCAN_WIRE,
                lambda: messages.laser_scan(stamp, frames["scan"], ranges, fleet.lidar, fleet.config.dt),
            )
            outputs["scan"].publish(wire.fill(sec, nanosec, ranges))
        reading = robot.beacon_reading() if "beacons" in outputs else None
        if reading is not None:
            outputs["beacons"].publish(messages.beacon_ranges(stamp, frames["world"], *reading, fleet.config.beacons))
        if "status" in outputs:
            localization = turn.check.state if turn.check is not None else False
            wire = channel.wire(
                "status",
                messages.STATUS_WIRE,
                lambda: messages.status(stamp, frames["world"], fleet, robot, turn.distance, rate, localization),
            )
            fields = messages.status_fields(fleet, robot, turn.distance, rate, localization)
            outputs["status"].publish(wire.fill(sec, nanosec, *(fields[name] for name in messages.STATUS_FIELDS)))

    def _publish_goals(self) -> None:
        """Each robot's goal on ~/goal (a fleet robot's on <name>/goal; latched), for a navigator to take as a goal;
        the goal check judges it."""
        for channel in self._robots:
            goal_region = self._fleet.robots[channel.index].goal
            if "goal" in channel.outputs:
                stamp = stamp_from_seconds(self._control.now())
                channel.outputs["goal"].publish(messages.goal_pose(stamp, channel.frames["world"], goal_region))

    def _publish_static_tf(self) -> None:
        """base -> scan: where the LiDAR sits on each robot (lidar.x, lidar.y), latched for late joiners (one
        message per tf_static topic: a latched topic keeps its last message only)."""
        lidar = self._fleet.lidar
        mountings: dict[int, tuple[object, list]] = {}
        for channel in self._robots:
            if channel.tf_static is not None:
                mounting = messages.transform(
                    stamp_from_seconds(self._control.now()),
                    channel.frames["base"],
                    channel.frames["scan"],
                    Pose2D(lidar.x, lidar.y, 0.0),
                )
                mountings.setdefault(id(channel.tf_static), (channel.tf_static, []))[1].append(mounting)
        for publisher, parts in mountings.values():
            publisher.publish(messages.tf_message(parts))

    # -- localization: beacons out, /pose in -------------------------------------------------

    def _create_localization_interfaces(self, channel: RobotChannel, qos) -> None:
        if self._fleet.world.beacons:
            channel.outputs["beacons"] = self._publisher(BeaconRanges, channel.topic("beacons"), qos)
        if self.get_parameter("enable_localization").value:
            channel.localization_inputs = [
                self.create_subscription(
                    LocalizedPose,
                    channel.topic("pose"),
                    lambda message: self._on_pose(channel, message),
                    qos,
                    event_callbacks=None if channel.name else REPORTED,
                )
            ]

    def _on_pose(self, channel: RobotChannel, message: LocalizedPose) -> None:
        try:
            pose = message.pose.pose
            stamp, theta = stamp_nanoseconds(message.header.stamp), yaw_from_quaternion(pose.orientation)
        except Exception as error:
            self.get_logger().warning(
                f"/{channel.prefix}pose not judged: {error}", throttle_duration_sec=WARNING_PERIOD
            )
            return
        self._control.pose(channel.index, stamp, pose.position.x, pose.position.y, theta, message.localized)

    # -- services --------------------------------------------------------------------------

    def _answer(self, response, action, failure: str, level: str = "warning"):
        """A reset or teleport: its line, or `failure` and the error (logged at `level`)."""
        try:
            response.success, response.message = True, action()
        except Exception as error:  # SimulationError: inside a wall or another robot, or not finite
            response.success, response.message = False, f"{failure}{error}"
            if level == "error":  # a line per severity: rclpy's logger keeps one severity per calling line
                self.get_logger().error(response.message)
            else:
                self.get_logger().warning(response.message)
        return response

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        return self._answer(response, self._control.reset, "reset failed: ", "error")

    def _on_set_pose(
        self, channel: RobotChannel, request: SetPose.Request, response: SetPose.Response
    ) -> SetPose.Response:
        x, y, theta = request.x, request.y, request.theta
        return self._answer(response, lambda: self._control.set_pose(channel.index, x, y, theta), channel.label)

    def _on_control(self, response: Trigger.Response, action) -> Trigger.Response:
        """A pause/resume/step request (create_active_service refuses them unless active): what happened."""
        try:
            response.success, response.message = True, action()
            self.get_logger().info(response.message)
        except Exception as error:
            response.success, response.message = False, f"{type(error).__name__}: {error}"
            self.get_logger().error(response.message)
        return response

    def _on_render(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        try:
            path = Path(self.get_parameter("render_path").value).expanduser().resolve()
            response.success, response.message = True, str(self._sim.render(path))
        except Exception as error:
            response.success, response.message = False, f"render failed: {type(error).__name__}: {error}"
            self.get_logger().error(response.message)
        return response


def main(args=None) -> None:
    run(SimulatorNode, args=args)


if __name__ == "__main__":
    main()
