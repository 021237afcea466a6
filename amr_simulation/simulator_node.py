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

An observation is, in this order, all stamped with the simulated time: /clock (realtime),
odometry, odom, ground_truth, scan, ~/status (each unless its publish_* parameter is false).
Activation, ~/reset and ~/set_pose each publish one observation too (a new starting point).
Stamps never go back: a reset restarts the simulator's own time (status sim_time), while the
stamps carry on one dt after the last one, so stamp-ordered consumers keep working.
"""

from __future__ import annotations

import math
import tempfile
import time
from collections import deque
from pathlib import Path

from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
from amr_interfaces.msg import SimulatorStatus
from amr_interfaces.srv import SetPose
from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import Clock as RclpyClock
from rclpy.clock import ClockType
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Trigger

from amr_control.managed_node import ManagedNode, run
from amr_simulation import messages
from amr_simulation.config import param_defaults
from amr_simulation.simulator import Simulator
from amr_simulation.world import world_search_dirs

LIBRARY_PARAMETERS = {**param_defaults(), "start": []}
"""The library's parameters (config/simulator.yaml) with their defaults; start [] = the world's."""
NODE_PARAMETERS = {
    "publish_odometry": (True, "odometry: nav_msgs/Odometry, encoder pose and encoder twist"),
    "publish_odom": (True, "odom: nav_msgs/Odometry, encoder pose, zero twist (a real TurtleBot3)"),
    "publish_ground_truth": (True, "ground_truth: nav_msgs/Odometry, true pose and body twist"),
    "publish_scan": (True, "scan: sensor_msgs/LaserScan, sensor-data QoS"),
    "publish_status": (True, "~/status: amr_interfaces/SimulatorStatus, after every observation"),
    "odom_frame": ("odom", "frame of odometry and odom poses (REP 105)"),
    "world_frame": ("map", "frame of ground_truth poses: the world, where odom starts"),
    "base_frame": ("base_footprint", "child frame of the odometry messages"),
    "scan_frame": ("base_scan", "frame of the LaserScan"),
    "qos_depth": (10, "queue depth of /cmd_vel and the reliable publishers"),
    "lockstep_resend_period": (1.0, "lockstep: wall-clock s without a /cmd_vel after which the last observation "
                                    "goes out again (one sent before the controller listened); 0 disables"),
    "render_path": (str(Path(tempfile.gettempdir()) / "amr_simulator.png"), "PNG file ~/render writes"),
}
WARNING_PERIOD = 5.0
"""s between repeats of a throttled warning."""
RATE_WINDOW = 20
"""Steps over which the status real-time factor is measured."""


def world_dirs() -> list[Path]:
    """Where a relative world name is looked up: the package share directory, then the library's."""
    try:
        share = [Path(get_package_share_directory("amr_simulation")) / "config" / "worlds"]
    except (PackageNotFoundError, EnvironmentError):
        share = []
    return share + list(world_search_dirs())


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
        library = ParameterDescriptor(
            dynamic_typing=True, description="amr_simulation.config; validated at configure")
        for name, default in LIBRARY_PARAMETERS.items():
            self.declare_parameter(name, default, library)
        for name, (default, description) in NODE_PARAMETERS.items():
            self.declare_parameter(name, default, ParameterDescriptor(description=description))
        self._sim: Simulator | None = None
        self._outputs: dict[str, object] = {}
        self._cmd_vel_subscription = None
        self._node_services: list = []
        self._step_timer = None
        self._last_output = 0.0
        self._frames: dict[str, str] = {}
        self._stamped = True
        self._active = False
        self._command = (0.0, 0.0)
        self._command_stamp = 0.0
        self._stamp_offset = 0.0
        self._distance = 0.0
        self._meter = RateMeter()

    # -- lifecycle -------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        try:
            self._sim = Simulator.from_params(self._library_parameters(), world_dirs())
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
        steady = RclpyClock(clock_type=ClockType.STEADY_TIME)  # immune to use_sim_time on this very node
        resend = self.get_parameter("lockstep_resend_period").value
        if config.mode == "realtime":
            self._step_timer = self.create_timer(config.dt / config.rate, self._on_timer, clock=steady)
        elif resend > 0.0:
            self._step_timer = self.create_timer(resend, self._on_resend_timer, clock=steady)
        self._active = True
        self._publish_observation()
        return result

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._active = False
        self._stop_timer()
        self._command = (0.0, 0.0)
        self.get_logger().info(f"stopped at t = {self._sim.time:.2f} s")
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._teardown()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: State) -> TransitionCallbackReturn:
        self._active = False
        self._teardown()
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self) -> None:
        self._active = False
        self._teardown()
        super().destroy_node()

    # -- building --------------------------------------------------------------------------

    def _library_parameters(self) -> dict:
        """The declared library parameters plus any undeclared override: the library names typos."""
        params = {name: self.get_parameter(name).value for name in LIBRARY_PARAMETERS}
        overrides = self._parameter_overrides  # rclpy keeps -p / --params-file values here
        params.update({name: p.value for name, p in overrides.items() if not self.has_parameter(name)})
        return params

    def _create_interfaces(self) -> None:
        get = lambda name: self.get_parameter(name).value  # noqa: E731
        reliable = QoSProfile(depth=get("qos_depth"), reliability=ReliabilityPolicy.RELIABLE)
        topics = {
            "odometry": (Odometry, reliable), "odom": (Odometry, reliable),
            "ground_truth": (Odometry, reliable), "scan": (LaserScan, qos_profile_sensor_data),
            "status": (SimulatorStatus, reliable),
        }
        for name, (kind, qos) in topics.items():
            if get(f"publish_{name}"):
                topic = "~/status" if name == "status" else name
                self._outputs[name] = self.create_lifecycle_publisher(kind, topic, qos)
        if self._sim.config.mode == "realtime":
            self._outputs["clock"] = self.create_lifecycle_publisher(Clock, "/clock", reliable)
        self._frames = {name: get(f"{name}_frame") for name in ("odom", "world", "base", "scan")}
        self._stamped = self._sim.config.cmd_vel_stamped
        self._cmd_vel_subscription = self.create_subscription(
            TwistStamped if self._stamped else Twist, "cmd_vel", self._on_cmd_vel, reliable)
        self._node_services = [
            self.create_service(Trigger, "~/reset", self._on_reset),
            self.create_service(SetPose, "~/set_pose", self._on_set_pose),
            self.create_service(Trigger, "~/render", self._on_render),
        ]

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

    def _stop_timer(self) -> None:
        if self._step_timer is not None:
            self.destroy_timer(self._step_timer)
            self._step_timer = None

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
            if self._sim.config.mode == "lockstep":
                self._advance(v, w) if finite else self._advance(0.0, 0.0)
            elif finite:
                self._command, self._command_stamp = (v, w), self._now()
        except Exception as error:
            self.get_logger().error(
                f"/cmd_vel callback: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD)

    def _on_timer(self) -> None:
        try:
            timeout = self._sim.config.command_timeout
            if timeout > 0.0 and self._command != (0.0, 0.0) and self._now() - self._command_stamp > timeout:
                self._command = (0.0, 0.0)
                self.get_logger().info(f"no /cmd_vel for {timeout} s: stopping")
            self._advance(*self._command)
        except Exception as error:
            self.get_logger().error(
                f"step timer: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD)

    def _on_resend_timer(self) -> None:
        """Lockstep waits for a command; if none came, the observation may have gone unheard."""
        if self._active and time.monotonic() - self._last_output > self.get_parameter("lockstep_resend_period").value:
            self.get_logger().info("no /cmd_vel since the last observation: publishing it again",
                                   throttle_duration_sec=WARNING_PERIOD)
            self._publish_observation()

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
            self._command = (0.0, 0.0)
            self.get_logger().info(
                f"goal reached at ({x:.3f}, {y:.3f}), t = {sim.time:.2f} s, {self._distance:.2f} m: stopping")
        self._publish_observation()

    def _publish_observation(self) -> None:
        self._last_output = time.monotonic()
        sim, frames, outputs = self._sim, self._frames, self._outputs
        now = self._now()
        stamp = messages.stamp(now)
        if "clock" in outputs:
            outputs["clock"].publish(messages.clock(stamp))
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
        rate = self._meter.update(now)
        if "status" in outputs:
            outputs["status"].publish(messages.status(stamp, sim, self._distance, rate))

    # -- services --------------------------------------------------------------------------

    def _restarted(self, what: str) -> str:
        """After a reset or teleport: the held command is dropped, a new first observation goes out."""
        self._command, self._command_stamp = (0.0, 0.0), self._now()
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
