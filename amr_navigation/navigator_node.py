"""navigator: who drives, observation by observation (lifecycle node, the ROS executor of NavigatorCore).

The one driver of /cmd_vel per robot, in the way nav2's bt_navigator is: it decides, the controllers act. Every
decision is amr_navigation.navigator_core.NavigatorCore's (the library loop runs the same core in process); this
node only turns messages into observations and the core's effects into ROS calls and publications:

- /pose (amr_interfaces/LocalizedPose: one per observation, with the localizer's confidence) -> an Observation
  (with the latest scan and the odometry of its stamp when the traffic rules or a fleet route need them);
- a PlanCall -> the planner's ~/plan (amr_interfaces/PlanPath; marks as obstacles): every path this robot drives,
  to its goal, around what is not on the map, and each leg of a fleet route, is the planner node's (it holds no
  planner of its own, as nav2's bt_navigator asks its planner_server); a HandOverCall -> the path
  follower's ~/follow_path (amr_interfaces/FollowPath), then /path (nav_msgs/Path, transient local) for viewers;
- the Outcome -> this robot's post on /traffic (when it says something new: same_post), speed_limit
  (amr_interfaces/SpeedLimit, stamped with the observation), then ~/status (amr_interfaces/NavigatorStatus,
  stamped with the /pose's stamp) naming the controller that answers the observation. The controllers run
  `navigated: true`: each answers only the observations whose status names it, so in lockstep exactly one
  /cmd_vel answers each observation across every hand-over.

Requests are made one at a time; an observation arriving meanwhile is decided after (the latest one), a plan the
path follower asked for (its ~/status) after the request in flight. A request unanswered for `plan_timeout` (wall
clock) counts as failed. Nobody drives (IDLE, NO_PATH, REACHED): the status names nobody, and what answers the
observation is the stack's declaration, `nobody_drives`. zero: this node answers it with a zero TwistStamped on
cmd_vel stamped with it, so in lockstep the robot stands while the world goes on (/clock, ~/status), and a new goal
or route is decided at the next observation. wait: no command; in lockstep the simulator waits on the observation,
a new goal or route decides it again (the status goes out again with the same stamp), and one held for want of a
path is decided again every RETRY_PERIOD; in real time the controller that had the robot stops it.

Goals: the `goal` parameter, geometry_msgs/PoseStamped on /goal_pose, and, with `world_goal_topic`, a latched
PoseStamped (the simulator's ~/goal). The latest one wins, at any time. With `traffic: true` the node also reads
`scan`, `/map` (for the rules' geometry: amr_planning.costmap.shared_costmap with the `costmap.*` parameters, the
planner node's costmap, which a composed process builds once for both) and everyone's
posts on /traffic (its own ignored, a malformed one dropped and logged, one older than post_timeout forgotten);
with `coordination: plan` also its fleet_route (amr_interfaces/FleetRoute) and odometry.
"""

from __future__ import annotations

import itertools
import math
import time
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from builtin_interfaces.msg import Time as TimeMessage
from geometry_msgs.msg import Point, Pose, PoseStamped, TwistStamped
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from nav_msgs.msg import Odometry, Path
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.lifecycle import State, TransitionCallbackReturn
from sensor_msgs.msg import LaserScan

from amr_interfaces.msg import FleetRoute, LocalizedPose, NavigatorStatus, PathFollowerStatus, SpeedLimit
from amr_interfaces.msg import TrafficPost as TrafficPostMessage
from amr_interfaces.srv import FollowPath, PlanPath
from amr_maps.messages import grid_from_message
from amr_navigation.fleet_coordinator import Route
from amr_navigation.fleet_route_messages import RouteError, route_from_message
from amr_navigation.navigator import Controller, Decision, Mode, Navigator
from amr_navigation.navigator_config import NODE_NAME, NavigatorConfig
from amr_navigation.navigator_core import (
    FollowerReport,
    HandOverCall,
    Job,
    NavigatorCore,
    Observation,
    Outcome,
    PlanAnswer,
    PlanCall,
)
from amr_navigation.traffic import Traffic
from amr_navigation.traffic_board import TrafficPost
from amr_navigation.traffic_messages import (
    POST_SPACING,
    POST_TOLERANCE,
    TRAFFIC_TOPIC,
    PostError,
    post_from_message,
    post_message,
    speed_limit_message,
)
from amr_navigation.traffic_steps import FleetBoard
from amr_planning.costmap import CostmapConfig, shared_costmap
from amr_planning.messages import path_message
from amr_util.geometry import all_finite, wrap_angle, yaw_from_quaternion
from amr_util.managed_node import ManagedNode, run
from amr_util.messages import path_points, quaternion, scan_data, velocity_command
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_util.stamps import stamp_nanoseconds
from amr_util.throttle import ThrottledLogger

CHECK_PERIOD = 0.5
"""s (wall clock) between checks of a request in flight against plan_timeout."""
QUIET = PublisherEventCallbacks(use_default_callbacks=False)
"""the publishers' event callbacks: none (two QoS-event waitables fewer per publisher in every wait set;
their subscribers' own handlers still report an incompatible QoS)."""
POST_MOVE, POST_TURN = 0.02, 0.05
"""m and rad a robot's pose (and the start of its path) may move before its post is published again."""
POST_KEEP_ALIVE = 500_000_000
"""ns (node clock): an unchanged post is published again this often (well within any post_timeout the others keep
it for: 0.1 s at the least)."""
ODOMETRY_KEPT = 200
"""odometry poses kept to pair with /pose by stamp (coordination plan)."""


WARNINGS = (
    "no path",
    "path refused",
    "replanning for the path follower failed",
    "no way around",
    "traffic rules without",
    "fleet route",
)
"""events logged as warnings (the others: info)."""
RETRY_PERIOD = 2.0
"""s (wall clock) between new attempts on an observation held for want of a path (a planner without its map
yet, a start the estimate put in a wall): in lockstep no new observation would come to try again."""


@dataclass(frozen=True)
class Received:
    """A /pose as it came: its stamp, the estimate, the localizer's verdict and confidence."""

    stamp: TimeMessage
    pose: tuple[float, float, float]
    localized: bool
    confidence: float | None


@dataclass
class InFlight:
    """The request in flight: the job waiting for its answer, the call, when it went out, the /pose it decides."""

    call_id: int
    job: Job
    call: PlanCall | HandOverCall
    started: float
    received: Received | None
    path: Path | None = None
    """a hand-over's path message (published on /path once taken)."""


def same_post(a: TrafficPost, b: TrafficPost) -> bool:
    """Two posts of one robot that tell the others the same: every flag, the pose within POST_MOVE and POST_TURN,
    the path to the same end from a start within POST_MOVE."""
    if (a.name, a.priority, a.blocked_by, a.yielding_to, a.passive, a.cannot_yield) != (
        b.name,
        b.priority,
        b.blocked_by,
        b.yielding_to,
        b.passive,
        b.cannot_yield,
    ):
        return False
    if (a.pose is None) != (b.pose is None) or (a.path is None) != (b.path is None):
        return False
    if a.pose is not None:
        if math.hypot(a.pose[0] - b.pose[0], a.pose[1] - b.pose[1]) > POST_MOVE:
            return False
        if abs(wrap_angle(a.pose[2] - b.pose[2])) > POST_TURN:
            return False
    if a.path is not None:
        if len(a.path) == 0 or len(b.path) == 0:
            return len(a.path) == len(b.path)
        if not np.array_equal(a.path[-1], b.path[-1]) or math.hypot(*(a.path[0] - b.path[0])) > POST_MOVE:
            return False
    return True


class NavigatorNode(ManagedNode):
    """Runs NavigatorCore on /pose, goals, routes and the path follower's reports; holds no decision logic."""

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(NavigatorConfig.parameter_specs())
        self.core: NavigatorCore | None = None
        self.statuses_sent = 0
        self.holds_sent = 0
        """zero commands sent for observations given to nobody (nobody_drives zero)."""
        self._values: dict = {}
        self._entities: list = []
        self._outputs: dict = {}
        self._service_clients: dict = {}
        self._timer = None
        self._ids = itertools.count(1)
        self._inflight: InFlight | None = None
        self._pending: Received | None = None
        self._follower_job: Job | None = None
        self._last: tuple[Received, Decision] | None = None
        self._last_decided = 0.0
        self._last_answered = False
        """the last observation was given to nobody and answered here (nobody_drives zero): the world has gone on."""
        self.configure_error = ""
        self.board: FleetBoard | None = None
        self.posts_dropped = 0
        self.routes_refused = 0
        self._scan: LaserScan | None = None
        self._costmap_config = CostmapConfig()
        self._odometry: OrderedDict[int, tuple[float, float, float]] = OrderedDict()
        """coordination plan: the latest odometry poses by stamp (ns), to pair with /pose."""
        self._last_post: tuple[TrafficPost, int] | None = None
        """the post last published on /traffic and when (ns, node clock)."""
        self._throttled = ThrottledLogger(lambda: self.get_logger(), 2.0)
        """warnings a node may repeat every step, decided before rclpy's logger resolves its caller."""

    @property
    def navigator(self) -> Navigator | None:
        return self.core.navigator if self.core is not None else None

    @property
    def traffic(self) -> Traffic | None:
        return self.core.traffic if self.core is not None else None

    @property
    def _route(self) -> Route | None:
        """the fleet planner's latest HOLD or FOLLOW for this robot (None: its own planning)."""
        return self.core.route if self.core is not None else None

    # -- lifecycle ------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if not problems:
            try:
                config = NavigatorConfig.from_params(self.parameter_values())
                values = config.as_params()
                goal = tuple(values["goal"]) if values["goal"] else None
                traffic = None
                if config.traffic:
                    name = self.get_namespace().strip("/") or self.get_name()
                    self.board = FleetBoard(config.post_timeout)
                    traffic = Traffic(name, config.priority, self.board, config.traffic_rules)
                core = NavigatorCore(
                    Navigator(goal, values["replan_distance"]),
                    traffic=traffic,
                    follower_speed=values["follower_speed"],
                    drive_confidence=values["drive_confidence"],
                    release_confidence=values["release_confidence"],
                )
            except ValueError as error:  # ConfigError names the key
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            self.board = None
            return self.fail_configure(problems)
        self.core, self._values = core, values
        self._outputs = {
            "status": self.create_lifecycle_publisher(NavigatorStatus, "~/status", reliable(), event_callbacks=QUIET),
            "path": self.create_lifecycle_publisher(Path, "path", LATCHED, event_callbacks=QUIET),
        }
        if values["nobody_drives"] == "zero":  # the answer to an observation given to nobody
            self._outputs["cmd_vel"] = self.create_lifecycle_publisher(
                TwistStamped, "cmd_vel", reliable(), event_callbacks=QUIET
            )
        self._entities = [
            self.create_subscription(LocalizedPose, "pose", self._on_pose, reliable()),
            self.create_subscription(PoseStamped, "goal_pose", self._on_goal, reliable()),
            self.create_subscription(
                PathFollowerStatus, f"{values['path_follower']}/status", self._on_follower, reliable()
            ),
        ]
        if values["world_goal_topic"]:
            self._entities.append(
                self.create_subscription(PoseStamped, values["world_goal_topic"], self._on_goal, LATCHED)
            )
        if values["traffic"]:
            self._configure_traffic(config)
        self._service_clients = {
            "plan": self.create_client(PlanPath, values["planner_service"]),
            "follow": self.create_client(FollowPath, values["follow_path_service"]),
        }
        self.get_logger().info(
            f"configured: plans with {values['planner_service']}, drives with {values['wall_follower']} (exploring) "
            f"and {values['path_follower']} (following a path from confidence {values['drive_confidence']:g} "
            f"until under {values['release_confidence']:g}); goal "
            + (f"({goal[0]:.2f}, {goal[1]:.2f})" if goal else "from /goal_pose")
            + (f" or {values['world_goal_topic']}" if values["world_goal_topic"] else "")
        )
        return TransitionCallbackReturn.SUCCESS

    def _configure_traffic(self, config: NavigatorConfig) -> None:
        self._costmap_config = config.costmap
        self._outputs["traffic"] = self.create_lifecycle_publisher(
            TrafficPostMessage, TRAFFIC_TOPIC, reliable(), event_callbacks=QUIET
        )
        self._outputs["speed_limit"] = self.create_lifecycle_publisher(
            SpeedLimit, "speed_limit", reliable(), event_callbacks=QUIET
        )
        self._entities += [
            self.create_subscription(TrafficPostMessage, TRAFFIC_TOPIC, self._on_post, reliable(depth=50)),
            self.create_subscription(LaserScan, "scan", self._on_scan, SENSOR_DATA),
            self.create_subscription(OccupancyGridMessage, "/map", self._on_map, LATCHED),
        ]
        self.get_logger().info(
            f"traffic rules on: {self.traffic.name}, priority {config.priority}, posts on {TRAFFIC_TOPIC}"
        )
        if config.coordination == "plan":
            self._entities += [
                self.create_subscription(FleetRoute, config.route_topic, self._on_route, LATCHED),
                self.create_subscription(Odometry, config.odometry_topic, self._on_odometry, reliable(depth=50)),
            ]
            self.get_logger().info(
                f"coordination by the fleet plan: routes on {config.route_topic}; the traffic rules until the first one"
            )

    def apply_live(self, changes: dict) -> None:
        """goal, replan_distance, plan_timeout, follower_speed, the confidences and the rules while configured: used
        from the next observation."""
        values = NavigatorConfig.from_params({**self._values, **changes}).as_params()  # ConfigError: refused
        core = self.core
        core.gate.set(values["drive_confidence"], values["release_confidence"])
        core.navigator.replan_distance = values["replan_distance"]
        core.follower_speed = values["follower_speed"]
        if core.traffic is not None:
            config = NavigatorConfig.from_params(values)
            core.traffic.config, self.board.timeout = config.traffic_rules, config.post_timeout
        if changes.get("goal"):
            self._set_goal(tuple(changes["goal"]), "the goal parameter")
        self._values = values

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._inflight, self._pending, self._follower_job, self._last = None, None, None, None
        self._last_answered = False
        self._last_post, self._odometry = None, OrderedDict()
        self.core.restart()
        self._timer = self.create_timer(
            CHECK_PERIOD, self._check_inflight, clock=Clock(clock_type=ClockType.STEADY_TIME)
        )
        return super().on_activate(state)

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._inflight, self._pending, self._follower_job = None, None, None  # late answers are ignored
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._entities, self._service_clients, self._outputs = [], {}, {}
        self.core = self.board = self._scan = None
        return super().on_cleanup(state)  # destroys what configure made

    @property
    def active(self) -> bool:
        return self.state_label == "active" and self.core is not None

    # -- inputs -----------------------------------------------------------------------------------

    def _on_pose(self, message: LocalizedPose) -> None:
        if not self.active:
            return
        p = message.pose.pose
        pose = (p.position.x, p.position.y, yaw_from_quaternion(p.orientation))
        if not all_finite(pose):
            self._throttled.warning("a non-finite /pose was ignored")
            return
        confidence = float(message.confidence) if math.isfinite(message.confidence) else None
        received = Received(message.header.stamp, pose, bool(message.localized), confidence)
        if self._inflight is not None:
            self._pending = received  # decided once the request in flight is answered
            return
        self._decide(received)

    def _on_scan(self, message: LaserScan) -> None:
        self._scan = message

    def _on_odometry(self, message: Odometry) -> None:
        p = message.pose.pose
        pose = (p.position.x, p.position.y, yaw_from_quaternion(p.orientation))
        if not all_finite(pose):
            return  # the localizer refuses it too; the pose to drive by stays the estimate
        self._odometry[stamp_nanoseconds(message.header.stamp)] = pose
        while len(self._odometry) > ODOMETRY_KEPT:
            self._odometry.popitem(last=False)

    def _on_route(self, message: FleetRoute) -> None:
        """The fleet planner's word for this robot: NONE (the traffic rules), HOLD or FOLLOW; a malformed one is
        refused with the reason logged, and the previous one stands."""
        if not self.active:
            return
        try:
            route = route_from_message(message, self._values["global_frame"], self._values.get("route_lifetime", 0.0))
        except RouteError as error:
            self.routes_refused += 1
            self.get_logger().error(f"fleet route refused, keeping the previous one: {error}")
            return
        self._log(self.core.set_route(route))
        if self.core.route is not None:
            self._decide_held_again()

    def _on_map(self, message: OccupancyGridMessage) -> None:
        try:  # the planner node's costmap (its costmap parameters are the navigator's costmap.*): one per process
            costmap = shared_costmap(grid_from_message(message), self._costmap_config)
        except Exception as error:  # a bad map must not take the node down
            self.get_logger().error(f"/map refused for the traffic rules, keeping the previous one: {error}")
            return
        if self.core is not None:
            self.core.set_map(costmap)

    def _on_post(self, message: TrafficPostMessage) -> None:
        """Another robot's post onto the board; a malformed one is dropped and logged, never raised."""
        if self.board is None or message.name == self.traffic.name:  # its own: not decoded
            return
        try:
            post = post_from_message(message, spacing=POST_SPACING)  # posted thinned (_posted)
        except (PostError, ValueError, TypeError) as error:
            self.posts_dropped += 1
            self._throttled.warning(f"a traffic post was dropped: {error}")
            return
        self.board.receive(post, stamp_nanoseconds(message.header.stamp) * 1e-9)

    def _on_goal(self, message: PoseStamped) -> None:
        if not self.active:
            return
        frame = self._values["global_frame"]
        if message.header.frame_id not in ("", frame):
            self.get_logger().warning(f"goal refused: frame {message.header.frame_id!r}, expected {frame!r}")
            return
        self._set_goal((message.pose.position.x, message.pose.position.y), "a goal message")

    def _set_goal(self, goal: tuple[float, float], source: str) -> None:
        try:
            self._log(self.core.set_goal(goal))
        except ValueError as error:
            self.get_logger().error(f"goal from {source} refused: {error}")
            return
        self._decide_held_again()

    def _on_follower(self, message: PathFollowerStatus) -> None:
        if not self.active:
            return
        report = FollowerReport(
            stamp_nanoseconds(message.header.stamp) * 1e-9,
            bool(message.reached),
            bool(message.replan),
            message.message,
            message.state,
        )
        result = self.core.report(report)
        if isinstance(result, Outcome):
            self._log(result.events)
        elif self._inflight is not None:
            self._follower_job = result  # after the request in flight
        else:
            self._run(result, None)

    # -- running the core's jobs ----------------------------------------------------------------------

    def _decide_held_again(self) -> None:
        """The robot is held on the last observation (nobody drives it, nobody answered it: nobody_drives wait): decide
        it again. One answered here (zero) is over: the next observation is decided with the news."""
        last = self._last
        held = last is not None and last[1].controller is Controller.NONE and not self._last_answered
        if held and self._inflight is None:
            self._decide(last[0])

    def _decide(self, received: Received) -> None:
        stamp_ns = stamp_nanoseconds(received.stamp)
        odometry = None
        if self._values.get("coordination") == "plan" and self.core.traffic is not None:
            odometry = self._odometry.get(stamp_ns)  # that of the observation, else the latest: at most a step off
            if odometry is None and self._odometry:
                odometry = next(reversed(self._odometry.values()))
        scan = scan_data(self._scan) if self.core.traffic is not None and self._scan is not None else None
        if self.board is not None:
            self.board.prune(self.get_clock().now().nanoseconds * 1e-9)
        observation = Observation(
            stamp_ns * 1e-9, received.pose, received.localized, received.confidence, odometry, scan
        )
        self._run(self.core.step(observation), received)

    def _run(self, job: Job, received: Received | None, answer=None, first: bool = True) -> None:
        """Advance a job to its next call (made here) or to its end (published)."""
        try:
            call = next(job) if first else job.send(answer)
        except StopIteration as stop:
            self._finish(received, stop.value)
            return
        except Exception as error:  # never out of a callback: the observation is dropped, the next one decided
            self.get_logger().error(f"deciding an observation failed: {type(error).__name__}: {error}")
            self._next()
            return
        if isinstance(call, PlanCall):
            client = self._service_clients["plan"]
            if not client.service_is_ready():
                self._run(job, received, PlanAnswer(None, f"{client.srv_name} is not available"), False)
                return
            request = self._plan_request(call)
            flight = InFlight(next(self._ids), job, call, time.monotonic(), received)
        else:
            client = self._service_clients["follow"]
            path = path_message(call.path, self._values["global_frame"], self.get_clock().now().to_msg())
            if not client.service_is_ready():
                self._run(job, received, f"{client.srv_name} is not available", False)
                return
            request = FollowPath.Request(path=path)
            flight = InFlight(next(self._ids), job, call, time.monotonic(), received, path)
        self._inflight = flight
        client.call_async(request).add_done_callback(lambda future: self._on_answer(flight.call_id, future))

    def _on_answer(self, call_id: int, future) -> None:
        flight = self._inflight
        if flight is None or flight.call_id != call_id:
            return  # timed out, or the node was deactivated meanwhile
        self._inflight = None
        if not self.active:
            return
        try:
            response = future.result()
        except Exception as error:
            self._answer(flight, f"{self._client_of(flight).srv_name} failed: {error!r}")
            return
        if isinstance(flight.call, PlanCall):
            if response.success and response.path.poses:
                answer = PlanAnswer(path_points(response.path))
            else:
                answer = PlanAnswer(None, response.message or "no path", bool(response.goal_refused))
            self._run(flight.job, flight.received, answer, False)
            return
        self._answer(flight, "" if response.success else response.message or "refused")

    def _answer(self, flight: InFlight, problem: str) -> None:
        """A failed request, or a hand-over's answer ('' taken: /path published), sent into its job."""
        if isinstance(flight.call, PlanCall):
            self._run(flight.job, flight.received, PlanAnswer(None, problem), False)
            return
        if not problem:
            self._outputs["path"].publish(flight.path)
        self._run(flight.job, flight.received, problem, False)

    def _client_of(self, flight: InFlight):
        return self._service_clients["plan" if isinstance(flight.call, PlanCall) else "follow"]

    def _plan_request(self, call: PlanCall) -> PlanPath.Request:
        request = PlanPath.Request()
        request.start.header.frame_id = request.goal.header.frame_id = self._values["global_frame"]
        request.start.pose.position.x, request.start.pose.position.y = float(call.start[0]), float(call.start[1])
        request.goal.pose.position.x, request.goal.pose.position.y = float(call.goal[0]), float(call.goal[1])
        if call.marks is not None and len(call.marks):  # planned around them on a copy of the costmap
            request.obstacles = [Point(x=float(x), y=float(y)) for x, y in call.marks]
            request.mark_radius = float(call.mark_radius)
        return request

    def _finish(self, received: Received | None, outcome: Outcome) -> None:
        """Publish a job's outcome (for an observation: post, speed limit, status), then go on with what waited."""
        if not self.active:
            return
        self._log(outcome.events)
        if received is not None and outcome.decision is not None:
            if outcome.post:
                self._posted()
            if outcome.limited and "speed_limit" in self._outputs:
                self._outputs["speed_limit"].publish(
                    speed_limit_message(outcome.speed_limit, received.stamp, self._values["global_frame"])
                )
            self._publish_status(received, outcome)
            self._last, self._last_decided = (received, outcome.decision), time.monotonic()
            self._last_answered = self._hold(received, outcome.decision)
        self._next()

    def _hold(self, received: Received, decision: Decision) -> bool:
        """nobody_drives zero: an observation given to nobody answered with a zero command stamped with it (the
        explicit hold: a lockstep world goes on); whether it was."""
        publisher = self._outputs.get("cmd_vel")
        if publisher is None or decision.controller is not Controller.NONE:
            return False
        publisher.publish(velocity_command(0.0, 0.0, stamped=True, flip_angular_sign=False, stamp=received.stamp))
        self.holds_sent += 1
        return True

    def _next(self) -> None:
        if self._follower_job is not None:
            job, self._follower_job = self._follower_job, None
            self._run(job, None)
        elif self._pending is not None:
            pending, self._pending = self._pending, None
            self._decide(pending)

    def _check_inflight(self) -> None:
        """A request the planner or the path follower did not answer within plan_timeout has failed; an
        observation held for want of a path is tried again every RETRY_PERIOD."""
        now = time.monotonic()
        flight = self._inflight
        if flight is None:
            held = self._last is not None and self._last[1].mode is Mode.NO_PATH and not self.navigator.goal_refused
            held = held and not self._last_answered  # answered: the next observation tries again
            if held and now - self._last_decided >= RETRY_PERIOD:
                self._decide(self._last[0])
            return
        if now - flight.started <= self._values["plan_timeout"]:
            return
        self._inflight = None
        self._answer(flight, f"{self._client_of(flight).srv_name}: no answer within {self._values['plan_timeout']} s")

    # -- outputs ----------------------------------------------------------------------------------

    def _posted(self) -> None:
        """Publish this robot's latest post (what the rules just put on the board) on /traffic, unless it says what
        the last one published did (same_post: within POST_MOVE and POST_TURN) and that one is younger than
        POST_KEEP_ALIVE (every post wakes every other navigator; most robots of a fleet stand, wait or
        explore, so most posts said nothing new)."""
        post = self.board.get(self.traffic.name) if self.board is not None else None
        if post is None:
            return
        now = self.get_clock().now()
        last = self._last_post
        if last is not None and same_post(last[0], post) and 0 <= now.nanoseconds - last[1] < POST_KEEP_ALIVE:
            return
        try:
            message = post_message(post, now.to_msg(), self._values["global_frame"], tolerance=POST_TOLERANCE)
            self._outputs["traffic"].publish(message)
            self._last_post = (post, now.nanoseconds)
        except PostError as error:  # never a NaN on /traffic
            self._throttled.error(f"own traffic post not sent: {error}")

    def _controller_name(self, controller: Controller) -> str:
        return {
            Controller.WALL_FOLLOWER: self._values["wall_follower"],
            Controller.PATH_FOLLOWER: self._values["path_follower"],
        }.get(controller, "")

    def _publish_status(self, received: Received, outcome: Outcome) -> None:
        navigator, decision = self.navigator, outcome.decision
        status = NavigatorStatus(
            mode=decision.mode.value,
            controller=self._controller_name(decision.controller),
            reason=decision.reason,
            localized=received.localized,
            confidence=outcome.confidence,
            confident=outcome.confident,
            has_goal=navigator.goal is not None,
            plans=navigator.counters.plans,
            planning_failures=len(navigator.counters.planning_failures),
        )
        status.header.stamp, status.header.frame_id = received.stamp, self._values["global_frame"]
        status.pose = self._pose_message(outcome.pose if outcome.pose is not None else received.pose)
        if navigator.goal is not None:
            status.goal.x, status.goal.y = navigator.goal
        self._outputs["status"].publish(status)
        self.statuses_sent += 1

    @staticmethod
    def _pose_message(pose: tuple[float, float, float]) -> Pose:
        message = Pose()
        message.position.x, message.position.y = pose[0], pose[1]
        message.orientation = quaternion(pose[2])
        return message

    def _log(self, events) -> None:
        for event in events:
            if event.startswith(WARNINGS):
                self.get_logger().warning(event)
            else:
                self.get_logger().info(event)


def main(args=None) -> None:
    run(NavigatorNode, args=args)


if __name__ == "__main__":
    main()
