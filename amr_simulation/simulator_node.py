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

Watching a run (issue 21): ~/pause holds the loop (lockstep: the /cmd_vel that answers the last
observation is kept, not stepped; realtime: the timer steps no more), ~/resume lets it go on (the
held command steps at once), ~/step advances exactly one step and stays paused (pausing first if
running; in lockstep with no command held yet, the next /cmd_vel is stepped when it comes, or, when none
has come for lockstep_resend_period, a step at zero velocity is taken: the driver holds the robot, as
a navigator does while nobody drives). While paused no observation is resent: /clock stops exactly. A
paused and stepped lockstep run is the run it would have been: every command still advances one dt,
in order. The live parameter `pace` sets the speed: lockstep 0 steps each command at once, N > 0 holds
each command until a steady timer at dt / N releases it (at most N x real time); realtime N > 0
replaces `rate`. ~/reset and ~/set_pose drop a held command (it answered the old observation).
Stamps never go back: a reset restarts the simulator's own time (status sim_time), while the
stamps carry on one dt after the last one, so stamp-ordered consumers keep working.

Localization (issue 12): a world that declares `beacons` adds /beacons (amr_interfaces/BeaconRanges:
noisy range to each beacon in the world's order, and a noisy compass) to every observation. With
`enable_localization` the node listens to /pose (a localizer's LocalizedPose), compares each estimate
with the true pose at its stamp, logs once when the robot is first localized ("localized at t = ...,
error x m, y deg") and reports the latest error in ~/status.
"""

from __future__ import annotations

import math
import time
from collections import deque
from pathlib import Path

from amr_interfaces.msg import BeaconRanges, LocalizedPose, SimulatorStatus
from amr_interfaces.srv import SetPose
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.clock import Clock as RclpyClock
from rclpy.clock import ClockType
from rclpy.lifecycle import State, TransitionCallbackReturn
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

from amr_maps.world import world_problem
from amr_simulation import messages
from amr_simulation.config import SimulationConfig
from amr_simulation.localization_check import LocalizationCheck
from amr_simulation.parameters import NODE_PARAMETERS, parameter_specs
from amr_simulation.simulator import Simulator
from amr_util.geometry import Pose2D, map_to_odom, yaw_from_quaternion
from amr_util.managed_node import ManagedNode, run
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_util.stamps import stamp_from_seconds, stamp_nanoseconds

TF_DEPTH = 100
"""Queue depth of /tf (tf2's dynamic broadcaster uses 100)."""
WARNING_PERIOD = 5.0
"""s between repeats of a throttled warning."""
RATE_WINDOW = 20
"""Steps over which the status real-time factor is measured."""


class RateMeter:
    """Simulated seconds per wall-clock second over the last RATE_WINDOW steps."""

    def __init__(self) -> None:
        self._samples: deque[tuple[float, float]] = deque(maxlen=RATE_WINDOW + 1)

    def clear(self) -> None:
        self._samples.clear()

    def update(self, sim_time: float) -> float:
        self._samples.append((sim_time, time.monotonic()))
        (sim0, wall0), (sim1, wall1) = self._samples[0], self._samples[-1]
        return (sim1 - sim0) / (wall1 - wall0) if wall1 > wall0 else 0.0


class SimulatorNode(ManagedNode):
    """A thin shell: parameters in, Simulator steps, messages out."""

    def __init__(self, **kwargs) -> None:
        super().__init__("simulator", **kwargs)
        self.declare_specs(parameter_specs(world_problem))
        self._sim: Simulator | None = None
        self._outputs: dict[str, object] = {}
        self._cmd_vel_subscription = None
        self._node_services: list = []
        self._resend_timer = None
        self._last_output = 0.0
        self._frames: dict[str, str] = {}
        self._tf_parts = (False, False)
        self._stamped = True
        self._active = False
        self._command = (0.0, 0.0)
        self._command_stamp = 0.0
        self._stamp_offset = 0.0
        self._distance = 0.0
        self._meter = RateMeter()
        self._localization_check: LocalizationCheck | None = None
        self._localization_inputs: list = []
        self._paused = False
        self._held: deque[tuple[float, float]] = deque()
        """Lockstep: commands received but not stepped yet (paused, or waiting for the pace timer)."""
        self._owed = 0
        """Steps ~/step asked for while paused, not taken yet."""
        self._pace_timer = None
        self._pace_ready = True
        self._steady = RclpyClock(clock_type=ClockType.STEADY_TIME)  # timers immune to use_sim_time on this node

    # -- lifecycle -------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if problems:
            return self.fail_configure(problems)
        try:
            self._sim = Simulator.from_params(self._library_parameters())
            self._create_interfaces()
        except Exception as error:  # ValueErrors name the key; anything else is reported as is
            self._teardown()
            detail = str(error) if isinstance(error, ValueError) else f"{type(error).__name__}: {error}"
            self.get_logger().error(f"configure failed: {detail}")
            return TransitionCallbackReturn.FAILURE
        self._stamp_offset = self._distance = 0.0
        config = self._sim.config
        self.get_logger().info(
            f"world {self._sim.world.name} ({self._sim.world.source}), mode {config.mode}, dt {config.dt} s"
            + (f", rate {config.rate}" if config.mode == "realtime" else ""))
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        result = super().on_activate(state)
        config = self._sim.config
        self._command, self._command_stamp = (0.0, 0.0), self._now()
        self._meter.clear()
        self._held.clear()
        self._paused, self._owed = False, 0
        resend = self.get_parameter("lockstep_resend_period").value
        if config.mode == "lockstep" and resend > 0.0:
            self._resend_timer = self.create_timer(resend, self._on_resend_timer, clock=self._steady)
        self._set_pace(self.get_parameter("pace").value)
        self._active = True
        self._publish_static_tf()
        self._publish_goal()
        self._publish_observation()
        return result

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._active = False
        self._stop_timer()
        self._command = (0.0, 0.0)
        self._held.clear()
        self.get_logger().info(f"stopped at t = {self._sim.time:.2f} s")
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._teardown()
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self) -> None:
        self._active = False
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
        if "pace" in changes and self._active:
            self._set_pace(changes["pace"])

    def _create_interfaces(self) -> None:
        get = lambda name: self.get_parameter(name).value  # noqa: E731
        qos = reliable(get("qos_depth"))
        topics = {
            "odometry": (Odometry, qos), "odom": (Odometry, qos),
            "ground_truth": (Odometry, qos), "scan": (LaserScan, SENSOR_DATA),
            "status": (SimulatorStatus, qos),
        }
        for name, (kind, qos) in topics.items():
            if get(f"publish_{name}"):
                topic = "~/status" if name == "status" else name
                self._outputs[name] = self.create_lifecycle_publisher(kind, topic, qos)
        if get("publish_clock"):
            self._outputs["clock"] = self.create_lifecycle_publisher(Clock, "/clock", qos)
        self._create_tf_publishers()
        if self._sim.world.goal is not None:
            self._outputs["goal"] = self.create_lifecycle_publisher(PoseStamped, "~/goal", LATCHED)
        self._frames = {name: get(f"{name}_frame") for name in ("odom", "world", "base", "scan")}
        self._stamped = self._sim.config.cmd_vel_stamped
        self._cmd_vel_subscription = self.create_subscription(
            TwistStamped if self._stamped else Twist, "cmd_vel", self._on_cmd_vel, qos)
        self._node_services = [
            self.create_active_service(Trigger, "~/reset", self._on_reset),
            self.create_active_service(SetPose, "~/set_pose", self._on_set_pose),
            self.create_active_service(Trigger, "~/render", self._on_render),
            self.create_active_service(Trigger, "~/pause", self._on_pause),
            self.create_active_service(Trigger, "~/resume", self._on_resume),
            self.create_active_service(Trigger, "~/step", self._on_step),
        ]
        self._create_localization_interfaces(qos)

    def _create_tf_publishers(self) -> None:
        """/tf (reliable, volatile) and /tf_static (transient local: late joiners get the mounting)."""
        self._tf_parts = (self.get_parameter("publish_tf").value, self.get_parameter("publish_map_to_odom").value)
        if self._tf_parts[0]:
            self._outputs["tf_static"] = self.create_lifecycle_publisher(TFMessage, "/tf_static", LATCHED)
        if any(self._tf_parts):
            self._outputs["tf"] = self.create_lifecycle_publisher(TFMessage, "/tf", reliable(TF_DEPTH))

    def _teardown(self) -> None:
        """Destroy whatever exists; safe on a half-built node."""
        self._stop_timer()
        for service in self._node_services:
            self.destroy_service(service)
        if self._cmd_vel_subscription is not None:
            self.destroy_subscription(self._cmd_vel_subscription)
        for publisher in self._outputs.values():
            self.destroy_lifecycle_publisher(publisher)
        self._node_services, self._cmd_vel_subscription, self._outputs, self._sim = [], None, {}, None
        for subscription in self._localization_inputs:
            self.destroy_subscription(subscription)
        self._localization_inputs, self._localization_check = [], None

    def _stop_timer(self) -> None:
        for timer in (self._resend_timer, self._pace_timer):
            if timer is not None:
                self.destroy_timer(timer)
        self._resend_timer = self._pace_timer = None

    def _set_pace(self, pace: float) -> None:
        """The steady timer that paces the steps: lockstep, none for 0 (a command steps at once); realtime, the
        step timer itself (dt / pace, or dt / rate for 0)."""
        if self._pace_timer is not None:
            self.destroy_timer(self._pace_timer)
            self._pace_timer = None
        config = self._sim.config
        if config.mode == "realtime":
            period = config.dt / (pace or config.rate)
            self._pace_timer = self.create_timer(period, self._on_timer, clock=self._steady)
        elif pace > 0.0:
            self._pace_ready = False
            self._pace_timer = self.create_timer(config.dt / pace, self._on_pace_timer, clock=self._steady)
        else:
            self._pace_ready = True
            self._release()

    # -- stepping --------------------------------------------------------------------------

    def _now(self) -> float:
        """The simulated time of the stamps: the simulator's time since reset plus an offset."""
        return self._stamp_offset + self._sim.time

    def _on_cmd_vel(self, message: TwistStamped | Twist) -> None:
        if not self._active:
            return
        try:
            twist = message.twist if self._stamped else message
            v, w = twist.linear.x, twist.angular.z
            finite = math.isfinite(v) and math.isfinite(w)
            if not finite:
                self.get_logger().warning(
                    f"refused a non-finite /cmd_vel (v={v}, w={w})", throttle_duration_sec=WARNING_PERIOD)
            elif self._sim.drive.saturation_scale(v, w) < 1.0:
                sv, sw = self._sim.drive.saturate(v, w)
                self.get_logger().warning(
                    f"/cmd_vel (v={v:.4g}, w={w:.4g}) beyond the robot's limits: saturated to (v={sv:.4g}, "
                    f"w={sw:.4g})", throttle_duration_sec=WARNING_PERIOD)
            if self._sim.config.mode == "lockstep":
                self._held.append((v, w) if finite else (0.0, 0.0))
                self._release()
            elif finite:
                self._command, self._command_stamp = (v, w), self._now()
        except Exception as error:
            self.get_logger().error(
                f"/cmd_vel callback: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD)

    def _release(self) -> None:
        """Lockstep: step the held commands, in order, as far as pausing and the pace allow."""
        while self._held and self._active:
            if self._paused:
                if self._owed <= 0:
                    return
                self._owed -= 1
            elif not self._pace_ready:
                return
            elif self._pace_timer is not None:
                self._pace_ready = False  # one step per pace period
            self._advance(*self._held.popleft())

    def _on_pace_timer(self) -> None:
        try:
            self._pace_ready = True
            self._release()
        except Exception as error:
            self.get_logger().error(
                f"pace timer: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD)

    def _on_timer(self) -> None:
        try:
            if self._paused:
                if self._owed <= 0:
                    return
                self._owed -= 1
            timeout = self._sim.config.command_timeout
            if timeout > 0.0 and self._command != (0.0, 0.0) and self._now() - self._command_stamp > timeout:
                self._command = (0.0, 0.0)
                self.get_logger().info(f"no /cmd_vel for {timeout} s: stopping")
            self._advance(*self._command)
        except Exception as error:
            self.get_logger().error(
                f"step timer: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD)

    def _on_resend_timer(self) -> None:
        """Lockstep waits for a command; if none came, the observation may have gone unheard (a held command
        was heard: the loop is paused or paced, not starved). Paused, nothing is resent (/clock stops); a step
        owed is taken at zero velocity instead (the driver holds the robot)."""
        try:
            if self._active and self._unanswered():
                if not self._paused:
                    self.get_logger().info("no /cmd_vel since the last observation: publishing it again",
                                           throttle_duration_sec=WARNING_PERIOD)
                    self._publish_observation()
                elif self._owed > 0:
                    self._owed -= 1
                    self._advance(0.0, 0.0)
        except Exception as error:
            self.get_logger().error(
                f"resend timer: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD)

    def _unanswered(self) -> bool:
        """Lockstep: no /cmd_vel has come for the last observation in lockstep_resend_period (0: never says so)."""
        period = self.get_parameter("lockstep_resend_period").value
        return period > 0.0 and not self._held and time.monotonic() - self._last_output > period

    def _advance(self, v: float, w: float) -> None:
        """One step, its log lines (contacts, goal) and its observation."""
        sim = self._sim
        collisions, reached = sim.collisions, sim.goal_reached
        sim.step(v, w)
        vx, vy, _ = sim.twist
        self._distance += math.hypot(vx, vy) * sim.config.dt
        x, y, _ = sim.pose
        if sim.collisions > collisions:
            self.get_logger().warning(f"collision {sim.collisions} at ({x:.3f}, {y:.3f}), t = {sim.time:.2f} s")
        if sim.goal_reached and not reached:
            stopping = sim.config.stop_at_goal
            if stopping:
                self._command = (0.0, 0.0)
            self.get_logger().info(
                f"goal reached at ({x:.3f}, {y:.3f}), t = {sim.time:.2f} s, {self._distance:.2f} m, "
                f"{sim.collisions} collisions" + (": stopping" if stopping else ""))
        self._publish_observation()

    def _publish_observation(self) -> None:
        self._last_output = time.monotonic()
        sim, frames, outputs = self._sim, self._frames, self._outputs
        now = self._now()
        stamp = stamp_from_seconds(now)
        if "clock" in outputs:
            outputs["clock"].publish(messages.clock(stamp))
        if "tf" in outputs:
            self._publish_tf(stamp)
        if "odometry" in outputs:
            v, w = sim.odom_twist
            outputs["odometry"].publish(
                messages.odometry(stamp, frames["odom"], frames["base"], sim.odom_pose, (v, 0.0, w)))
        if "odom" in outputs:
            outputs["odom"].publish(
                messages.odometry(stamp, frames["odom"], frames["base"], sim.odom_pose, (0.0, 0.0, 0.0)))
        if "ground_truth" in outputs:
            outputs["ground_truth"].publish(
                messages.odometry(stamp, frames["world"], frames["base"], sim.pose, sim.twist))
        if "scan" in outputs:
            outputs["scan"].publish(messages.laser_scan(stamp, frames["scan"], sim.ranges, sim.lidar, sim.config.dt))
        self._publish_localization_inputs(stamp)
        rate = self._meter.update(now)
        if "status" in outputs:
            status = messages.status(stamp, frames["world"], sim, self._distance, rate)
            self._report_localization(status)
            outputs["status"].publish(status)

    # -- localization (issue 12): beacons out, /pose checked against the ground truth -------------

    def _create_localization_interfaces(self, qos) -> None:
        if self._sim.world.beacons:
            self._outputs["beacons"] = self.create_lifecycle_publisher(BeaconRanges, "beacons", qos)
        if self.get_parameter("enable_localization").value:
            self._localization_check = LocalizationCheck()
            self._localization_inputs = [self.create_subscription(LocalizedPose, "pose", self._on_pose, qos)]

    def _publish_localization_inputs(self, stamp) -> None:
        """Per observation: the beacon reading, and the true pose the next /pose will be judged against."""
        if self._localization_check is not None:
            self._localization_check.observed(stamp_nanoseconds(stamp), self._sim.pose, self._sim.time)
        reading = self._sim.beacon_reading() if "beacons" in self._outputs else None
        if reading is not None:
            self._outputs["beacons"].publish(messages.beacon_ranges(stamp, self._frames["world"], *reading,
                                                                    self._sim.config.beacons))

    def _on_pose(self, message: LocalizedPose) -> None:
        try:
            pose = message.pose.pose
            theta = yaw_from_quaternion(pose.orientation)
            stamp = stamp_nanoseconds(message.header.stamp)
            line = self._localization_check.estimate(stamp, pose.position.x, pose.position.y, theta, message.localized)
            if line:
                self.get_logger().info(line)
        except Exception as error:  # a NaN or stale estimate: say so, keep simulating
            self.get_logger().warning(f"/pose not judged: {error}", throttle_duration_sec=WARNING_PERIOD)

    def _report_localization(self, status: SimulatorStatus) -> None:
        check = self._localization_check
        status.localization_enabled = check is not None
        state = check.state if check is not None else None
        status.localized = bool(state and state.localized)
        status.first_localized_time = state.first_localized_time if state else -1.0
        status.position_error = state.position_error if state else math.nan
        status.heading_error = state.heading_error if state else math.nan

    def _publish_tf(self, stamp) -> None:
        """odom -> base (encoder odometry) and, when asked, the ground-truth map -> odom; one TFMessage."""
        sim, frames = self._sim, self._frames
        odom_to_base, map_to_odom_wanted = self._tf_parts
        transforms = []
        if odom_to_base:
            transforms.append(messages.transform(stamp, frames["odom"], frames["base"], sim.odom_pose))
        if map_to_odom_wanted:
            transforms.append(messages.transform(
                stamp, frames["world"], frames["odom"], map_to_odom(sim.pose, sim.odom_pose)))
        self._outputs["tf"].publish(messages.tf_message(transforms))

    def _publish_goal(self) -> None:
        """The world's goal on ~/goal (latched), for a navigator to take as a goal; the goal check judges it."""
        if "goal" in self._outputs:
            goal = PoseStamped()
            goal.header.stamp, goal.header.frame_id = stamp_from_seconds(self._now()), self._frames["world"]
            goal.pose.position.x, goal.pose.position.y = self._sim.goal.x, self._sim.goal.y
            goal.pose.orientation.w = 1.0
            self._outputs["goal"].publish(goal)

    def _publish_static_tf(self) -> None:
        """base -> scan: where the LiDAR sits on the robot (lidar.x, lidar.y), latched for late joiners."""
        if "tf_static" in self._outputs:
            lidar = self._sim.lidar
            mounting = messages.transform(stamp_from_seconds(self._now()), self._frames["base"], self._frames["scan"],
                                          Pose2D(lidar.x, lidar.y, 0.0))
            self._outputs["tf_static"].publish(messages.tf_message([mounting]))

    # -- services --------------------------------------------------------------------------

    def _restarted(self, what: str) -> str:
        """After a reset or teleport: the held command is dropped, a new first observation goes out."""
        self._command, self._command_stamp = (0.0, 0.0), self._now()
        self._held.clear()
        self._owed = 0
        self._meter.clear()
        if self._active:
            self._publish_observation()
        x, y, theta = self._sim.pose
        message = f"{what}: robot at ({x:.3f}, {y:.3f}, {theta:.3f})"
        self.get_logger().info(message)
        return message

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        try:
            self._stamp_offset = self._now() + self._sim.config.dt
            self._sim.reset()
            self._distance = 0.0
            response.success, response.message = True, self._restarted("reset")
        except Exception as error:
            response.success, response.message = False, f"reset failed: {error}"
            self.get_logger().error(response.message)
        return response

    def _on_set_pose(self, request: SetPose.Request, response: SetPose.Response) -> SetPose.Response:
        try:
            self._sim.set_pose(request.x, request.y, request.theta)
            self._stamp_offset += self._sim.config.dt
            response.success, response.message = True, self._restarted("set_pose")
        except Exception as error:  # SimulationError: inside a wall, or not finite
            response.success, response.message = False, str(error)
            self.get_logger().warning(response.message)
        return response

    def _on_pause(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        return self._control(response, self._pause)

    def _on_resume(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        return self._control(response, self._resume)

    def _on_step(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        return self._control(response, self._step_once)

    def _control(self, response: Trigger.Response, action) -> Trigger.Response:
        """A pause/resume/step request (create_active_service refuses them unless active): what happened."""
        try:
            response.success, response.message = True, action()
            self.get_logger().info(response.message)
        except Exception as error:
            response.success, response.message = False, f"{type(error).__name__}: {error}"
            self.get_logger().error(response.message)
        return response

    def _pause(self) -> str:
        was = self._paused
        self._paused, self._owed = True, 0
        return f"{'already ' if was else ''}paused at t = {self._sim.time:.2f} s (step {self._sim.steps})"

    def _resume(self) -> str:
        was = self._paused
        self._paused, self._owed = False, 0
        self._release()
        return f"{'running' if was else 'already running'} from t = {self._sim.time:.2f} s (step {self._sim.steps})"

    def _step_once(self) -> str:
        note = "" if self._paused else "paused; "
        self._paused = True
        steps = self._sim.steps
        self._owed += 1
        if self._sim.config.mode == "lockstep":
            self._release()
            if self._owed > 0 and self._unanswered():  # the driver holds the robot: no command is coming
                self._owed -= 1
                self._advance(0.0, 0.0)
        if self._sim.steps > steps:
            return f"{note}stepped to t = {self._sim.time:.2f} s (step {self._sim.steps})"
        waiting = "the next /cmd_vel (or at zero velocity if none comes)" if self._sim.config.mode == "lockstep" \
            else "the next tick"
        return f"{note}{self._owed} step(s) owed at t = {self._sim.time:.2f} s: taken on {waiting}"

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
