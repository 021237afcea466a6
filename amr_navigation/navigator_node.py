"""navigator: who drives, observation by observation (lifecycle node, a thin shell over amr_navigation.Navigator).

The one driver of /cmd_vel per robot, in the way nav2's bt_navigator is: it decides, the controllers
act. For every /pose (amr_interfaces/LocalizedPose: one per observation, from the localizer) it asks
the Navigator who answers that observation, carries the decision out, and publishes it on ~/status
(amr_interfaces/NavigatorStatus) stamped with the /pose's stamp. The controllers run `navigated: true`:
each pairs that status with its own inputs of the same observation and answers only when the status
names it, so in lockstep exactly one /cmd_vel answers each observation across every hand-over, and no
controller needs to listen to /cmd_vel to guess whether another one answered.

Carrying a decision out, before the status goes out:
- a plan: the planner's ~/plan (amr_interfaces/PlanPath) from the estimate to the goal;
- a new path: the path follower's ~/follow_path (amr_interfaces/FollowPath), so the path is in place
  before the observation that needs it; then /path (nav_msgs/Path, transient local) for viewers;
- nobody drives (IDLE, NO_PATH, REACHED): the status names nobody and says why; in lockstep the
  simulator then holds the robot. A new goal re-decides the held observation (the status goes out again
  with the same stamp, and the named controller answers the observation it holds).
Requests are made one at a time; an observation arriving meanwhile is decided after (the latest one).
A request unanswered for `plan_timeout` (wall clock) counts as failed.

Goals: the `goal` parameter, geometry_msgs/PoseStamped on /goal_pose (RViz's 2D Goal Pose, the
command line), and, with `world_goal_topic`, a latched PoseStamped (the simulator's ~/goal: the world's
goal). The latest one wins, at any time, before or after arrival. The path follower's ~/status
(amr_interfaces/PathFollowerStatus) reports arrival and requests for a new plan.

Traffic rules among robots (`traffic: true`, the fleet_navigation stack; amr_navigation.traffic): the node keeps
the latest scan (sensor-data QoS) and the one /map (transient local; the costmap built as the planner node builds
it, from the `costmap.*` parameters, which the fleet_navigation stack ties to the planner's), publishes this
robot's post (amr_interfaces/TrafficPost, its name is the namespace) on the absolute topic /traffic and reads
everyone's (its own ignored, a malformed one dropped and logged, one older than post_timeout forgotten) into a
board, and on every observation calls the rules as NavigationLoop does (amr_navigation.traffic_steps holds what
both share): the advice's speed limit goes out on speed_limit (amr_interfaces/SpeedLimit, stamped with the
observation, before the status), a replan around marks is a ~/plan request carrying the marks as obstacles, a
detour is handed to the path follower, a hold or a replan is a speed limit of 0 for that observation. With the
rules, a robot at its goal (REACHED) and one holding still are answered by the path follower with a limit of 0
(not by nobody): the others still need the lockstep world to go on, and a robot at its goal may have to make way.
"""

from __future__ import annotations

import itertools
import math
import time
from collections import OrderedDict
from dataclasses import dataclass, replace

import numpy as np
from builtin_interfaces.msg import Time as TimeMessage
from geometry_msgs.msg import Point, Pose, PoseStamped
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
from amr_navigation.fleet_coordinator import HOLD, NONE, Route
from amr_navigation.fleet_route_messages import RouteError, route_from_message
from amr_navigation.fleet_schedule import STOPPED_SHORT, DeadReckoning, HandOver, legs
from amr_navigation.navigator import Controller, Decision, Mode, Navigator, PlanRequest
from amr_navigation.navigator_config import NODE_NAME, NavigatorConfig
from amr_navigation.traffic import Traffic, TrafficPost
from amr_navigation.traffic_messages import (
    TRAFFIC_TOPIC,
    PostError,
    post_from_message,
    post_message,
    speed_limit_message,
)
from amr_navigation.traffic_steps import FleetBoard, detour_done, idle_advice
from amr_planning.costmap import Costmap, CostmapConfig
from amr_planning.messages import path_message
from amr_planning.planner import Planner
from amr_util.geometry import all_finite, wrap_angle, yaw_from_quaternion
from amr_util.managed_node import ManagedNode, run
from amr_util.messages import path_points, quaternion, scan_data
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_util.stamps import stamp_nanoseconds

CHECK_PERIOD = 0.5
"""s (wall clock) between checks of a request in flight against plan_timeout."""
QUIET = PublisherEventCallbacks(use_default_callbacks=False)
"""the publishers' event callbacks: none (two QoS-event waitables fewer per publisher in every wait set, issue 36;
their subscribers' own handlers still report an incompatible QoS)."""
POST_MOVE, POST_TURN = 0.02, 0.05
"""m and rad a robot's pose (and the start of its path) may move before its post is published again."""
POST_KEEP_ALIVE = 500_000_000
"""ns (node clock): an unchanged post is published again this often (well within any post_timeout the others keep
it for: 0.1 s at the least)."""
ODOMETRY_KEPT = 200
"""odometry poses kept to pair with /pose by stamp (coordination plan)."""
STOPPED_SHORT_STATES = tuple(state.value for state in STOPPED_SHORT)


RETRY_PERIOD = 2.0
"""s (wall clock) between new attempts on an observation held for want of a path (a planner without its map
yet, a start the estimate put in a wall): in lockstep no new observation would come to try again."""


@dataclass(frozen=True)
class Observation:
    stamp: TimeMessage
    pose: tuple[float, float, float]
    localized: bool
    on_route: bool = False
    """decided on the fleet route (coordination plan); pose is then the pose driven by."""


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
    """Wires Navigator to /pose, goals, the planner, the path follower and ~/status; holds no decision logic."""

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(NavigatorConfig.parameter_specs())
        self.navigator: Navigator | None = None
        self.statuses_sent = 0
        self._values: dict = {}
        self._entities: list = []
        self._outputs: dict = {}
        self._service_clients: dict = {}
        self._timer = None
        self._ids = itertools.count(1)
        self._inflight: tuple | None = None  # (id, kind, started, request or path, observation or None)
        self._pending: Observation | None = None
        self._follower_request: PlanRequest | None = None
        self._last: tuple[Observation, Decision] | None = None
        self._last_decided = 0.0
        self.configure_error = ""
        self.traffic: Traffic | None = None
        self.board: FleetBoard | None = None
        self.posts_dropped = 0
        self._scan: LaserScan | None = None
        self._map_planner: Planner | None = None
        self._costmap_config = CostmapConfig()
        self._advised: tuple[int, float | None] | None = None  # (observation stamp ns, speed limit)
        self._reports_after = -1
        """traffic: the path follower's reports up to this observation stamp (ns) are of a path the rules dropped."""
        self._route: Route | None = None
        """coordination plan: the fleet planner's latest HOLD or FOLLOW for this robot (None: the traffic rules)."""
        self._hand_over_due = HandOver()
        self._reckoning = DeadReckoning()
        self._odometry: OrderedDict[int, tuple[float, float, float]] = OrderedDict()
        """coordination plan: the latest odometry poses by stamp (ns), to pair with /pose."""
        self._route_handed_at = -1
        """coordination plan: the observation stamp (ns) the path follower's route path was handed over at; its
        reports of earlier observations are of an older path."""
        self._follower_blocked = False
        self.routes_refused = 0
        self._last_post: tuple[TrafficPost, int] | None = None
        """the post last published on /traffic and when (ns, node clock)."""

    # -- lifecycle ------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if not problems:
            try:
                values = NavigatorConfig.from_params(self.parameter_values()).as_params()
                goal = tuple(values["goal"]) if values["goal"] else None
                navigator = Navigator(goal, values["replan_distance"])
            except ValueError as error:  # ConfigError names the key
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            return self.fail_configure(problems)
        self.navigator, self._values = navigator, values
        self._outputs = {
            "status": self.create_lifecycle_publisher(NavigatorStatus, "~/status", reliable(), event_callbacks=QUIET),
            "path": self.create_lifecycle_publisher(Path, "path", LATCHED, event_callbacks=QUIET),
        }
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
            self._configure_traffic(NavigatorConfig.from_params(values))
        self._service_clients = {
            "plan": self.create_client(PlanPath, values["planner_service"]),
            "follow": self.create_client(FollowPath, values["follow_path_service"]),
        }
        self.get_logger().info(
            f"configured: plans with {values['planner_service']}, drives with {values['wall_follower']} (exploring) "
            f"and {values['path_follower']} (following); goal "
            + (f"({goal[0]:.2f}, {goal[1]:.2f})" if goal else "from /goal_pose")
            + (f" or {values['world_goal_topic']}" if values["world_goal_topic"] else "")
        )
        return TransitionCallbackReturn.SUCCESS

    def _configure_traffic(self, config: NavigatorConfig) -> None:
        name = self.get_namespace().strip("/") or self.get_name()
        self.board = FleetBoard(config.post_timeout)
        self.traffic = Traffic(name, config.priority, self.board, config.traffic_rules)
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
        self.get_logger().info(f"traffic rules on: {name}, priority {config.priority}, posts on {TRAFFIC_TOPIC}")
        if config.coordination == "plan":
            self._entities += [
                self.create_subscription(FleetRoute, config.route_topic, self._on_route, LATCHED),
                self.create_subscription(Odometry, config.odometry_topic, self._on_odometry, reliable(depth=50)),
            ]
            self.get_logger().info(
                f"coordination by the fleet plan: routes on {config.route_topic}; the traffic rules until the first one"
            )

    def apply_live(self, changes: dict) -> None:
        """goal, replan_distance and plan_timeout while configured: used from the next observation."""
        values = NavigatorConfig.from_params({**self._values, **changes}).as_params()  # ConfigError: refused
        if "replan_distance" in changes:
            self.navigator.replan_distance = values["replan_distance"]
        if self.traffic is not None:
            config = NavigatorConfig.from_params(values)
            self.traffic.config, self.board.timeout = config.traffic_rules, config.post_timeout
        if changes.get("goal"):
            self._set_goal(tuple(changes["goal"]), "the goal parameter")
        self._values = values

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._inflight, self._pending, self._follower_request, self._last = None, None, None, None
        self._advised, self._reports_after = None, -1
        self._route, self._route_handed_at, self._follower_blocked = None, -1, False
        self._last_post = None
        self._hand_over_due.reset()
        self._reckoning, self._odometry = DeadReckoning(), OrderedDict()
        self._timer = self.create_timer(
            CHECK_PERIOD, self._check_inflight, clock=Clock(clock_type=ClockType.STEADY_TIME)
        )
        return super().on_activate(state)

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._inflight, self._pending, self._follower_request = None, None, None  # late answers are ignored
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        for subscription in self._entities:
            self.destroy_subscription(subscription)
        for client in self._service_clients.values():
            self.destroy_client(client)
        for publisher in self._outputs.values():
            self.destroy_lifecycle_publisher(publisher)
        self._entities, self._service_clients, self._outputs = [], {}, {}
        self.navigator = None
        self.traffic = self.board = self._scan = self._map_planner = self._advised = None
        return TransitionCallbackReturn.SUCCESS

    @property
    def active(self) -> bool:
        return self.state_label == "active" and self.navigator is not None

    # -- inputs -----------------------------------------------------------------------------------

    def _on_pose(self, message: LocalizedPose) -> None:
        if not self.active:
            return
        p = message.pose.pose
        pose = (p.position.x, p.position.y, yaw_from_quaternion(p.orientation))
        if not all_finite(pose):
            self.get_logger().warning("a non-finite /pose was ignored", throttle_duration_sec=2.0)
            return
        observation = Observation(message.header.stamp, pose, bool(message.localized))
        if self._inflight is not None:
            self._pending = observation  # decided once the request in flight is answered
            return
        self._decide(observation)

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
        before, self._route = self._route, (None if route.state == NONE else route)
        if self._route is None:
            if before is not None:  # back to the rules: they plan to the goal anew
                self.navigator.plan_again(f"no fleet plan ({route.reason or 'withdrawn'}): by the traffic rules")
                self._log(self.navigator.take_events())
            self._hand_over_due.reset()
            return
        if before is None or before.plan != route.plan:
            self.get_logger().info(
                f"fleet plan {route.plan}: {route.state}" + (f" ({route.reason})" if route.reason else "")
            )
        if self._last is not None and self._last[1].controller is Controller.NONE and self._inflight is None:
            self._decide(self._last[0])  # the robot is held on this observation: decide it again

    def _on_map(self, message: OccupancyGridMessage) -> None:
        try:  # the costmap as the planner node builds it (its costmap parameters are the navigator's costmap.*)
            grid = grid_from_message(message)
            self._map_planner = Planner(grid, costmap=Costmap(grid, self._costmap_config))
        except Exception as error:  # a bad map must not take the node down
            self.get_logger().error(f"/map refused for the traffic rules, keeping the previous one: {error}")

    def _on_post(self, message: TrafficPostMessage) -> None:
        """Another robot's post onto the board; a malformed one is dropped and logged, never raised."""
        if self.board is None:
            return
        try:
            post = post_from_message(message)
        except (PostError, ValueError, TypeError) as error:
            self.posts_dropped += 1
            self.get_logger().warning(f"a traffic post was dropped: {error}", throttle_duration_sec=2.0)
            return
        if post.name == self.traffic.name:
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
            self.navigator.set_goal(goal)
        except ValueError as error:
            self.get_logger().error(f"goal from {source} refused: {error}")
            return
        self._log(self.navigator.take_events())
        if self._last is not None and self._last[1].controller is Controller.NONE and self._inflight is None:
            self._decide(self._last[0])  # the robot is held on this observation: decide it again

    def _on_follower(self, message: PathFollowerStatus) -> None:
        if not self.active:
            return
        stamp_ns = stamp_nanoseconds(message.header.stamp)
        stamp = stamp_ns * 1e-9
        if self._route is not None:  # on the fleet route: blocked (retried by HandOver), and the goal reached
            if stamp_ns >= self._route_handed_at:
                self._follower_blocked = message.state in STOPPED_SHORT_STATES
                if message.reached and self._route.final and not self.navigator.on_detour:
                    self.navigator.followed(True, False)
                    self._log(self.navigator.take_events())
            return
        if self.traffic is not None and stamp_ns <= self._reports_after:
            return  # about the path the rules just dropped (a detour's end reached again): a plan is due
        if detour_done(self.traffic, self.navigator, message.reached, stamp):
            return  # at the place aside: the rules wait there
        if self.traffic is not None and message.reached and self.navigator.mode is Mode.REACHED:
            return  # held at its goal by the path follower (traffic): arrival was already taken
        request = self.navigator.followed(message.reached, message.replan, message.message)
        self._log(self.navigator.take_events())
        if request is None:
            return
        if self._inflight is not None:
            self._follower_request = request
            return
        self._carry_out(None, Decision(self.navigator.mode, Controller.NONE, plan=request))

    # -- carrying a decision out ---------------------------------------------------------------------

    def _decide(self, observation: Observation) -> None:
        if self._values.get("coordination") == "plan":
            driving = self._driving_pose(observation)  # every observation: the last sure estimate is kept
            if self._route is not None and stamp_nanoseconds(observation.stamp) * 1e-9 > self._route.expires:
                self.get_logger().warning(  # the fleet planner is silent (gone, or still planning): plan alone
                    f"fleet route of plan {self._route.plan} expired at {self._route.expires:.2f} s: by the traffic "
                    "rules until a new one"
                )
                self._route = None
                self.navigator.plan_again("the fleet route expired: by the traffic rules")
                self._log(self.navigator.take_events())
                self._hand_over_due.reset()
            if self._route is not None:
                self._decide_on_route(replace(observation, pose=driving, on_route=True))
                return
        self._carry_out(observation, self.navigator.decide(observation.pose, observation.localized))

    def _driving_pose(self, observation: Observation) -> tuple[float, float, float]:
        """Coordination plan: the pose to drive by (DeadReckoning on the odometry of the observation's stamp, the
        latest one if none has it: at most a step off; the estimate before any odometry came)."""
        odometry = self._odometry.get(stamp_nanoseconds(observation.stamp))
        if odometry is None and self._odometry:
            odometry = next(reversed(self._odometry.values()))
        if odometry is None:
            return observation.pose
        return self._reckoning.pose(observation.pose, observation.localized, odometry)

    def _decide_on_route(self, observation: Observation) -> None:
        """One observation on the fleet route: hold (HOLD), or the path follower driven through the waypoints it
        may drive to now, a new path handed over whenever they change or BLOCKED_RETRY s after it was blocked."""
        route, navigator = self._route, self.navigator
        if route.state == HOLD:
            self._finish(observation, navigator.on_route(observation.pose, "holding: the fleet is being planned"))
            return
        why = f"fleet plan {route.plan}: waypoint {route.progress} of {route.total}"
        stamp_ns = stamp_nanoseconds(observation.stamp)
        key = (route.plan, route.progress, route.waypoints.tobytes())
        if not self._hand_over_due.due(key, self._follower_blocked, stamp_ns * 1e-9):
            self._finish(observation, navigator.on_route(observation.pose, why))
            return
        if self._map_planner is None:  # legs need the map: hold until it came, then hand over
            self.get_logger().warning("fleet route without /map yet: holding", throttle_duration_sec=2.0)
            self._hand_over_due.reset()
            self._finish(observation, navigator.on_route(observation.pose, "holding: no /map yet"))
            return
        path = legs(self._map_planner, np.vstack([observation.pose[:2], route.waypoints]))
        self._route_handed_at, self._follower_blocked = stamp_ns, False
        self._log((navigator.adopt if route.final else navigator.detour)(path, why).events)
        decision = replace(navigator.on_route(observation.pose, why), path=path)
        self._carry_out(observation, decision)

    def _carry_out(self, observation: Observation | None, decision: Decision) -> None:
        """Plan, then hand the path over, then publish the decision (for an observation; a follower's request
        publishes nothing)."""
        self._log(decision.events)
        if decision.plan is not None:
            self._ask_planner(observation, decision.plan)
        elif decision.path is not None:
            self._hand_over(observation, decision)
        else:
            self._finish(observation, decision)

    def _plan_request(self, start, goal, marks: np.ndarray | None) -> PlanPath.Request:
        request = PlanPath.Request()
        request.start.header.frame_id = request.goal.header.frame_id = self._values["global_frame"]
        request.start.pose.position.x, request.start.pose.position.y = float(start[0]), float(start[1])
        request.goal.pose.position.x, request.goal.pose.position.y = float(goal[0]), float(goal[1])
        if marks is not None and len(marks):  # the traffic rules' marks: planned around on a copy of the costmap
            request.obstacles = [Point(x=float(x), y=float(y)) for x, y in marks]
            request.mark_radius = float(self.traffic.config.mark_radius)
        return request

    def _ask_planner(self, observation: Observation | None, plan: PlanRequest) -> None:
        client = self._service_clients["plan"]
        if not client.service_is_ready():
            self._planned(observation, plan, None, f"{client.srv_name} is not available", False)
            return
        marks = self.traffic.marks if self.traffic is not None else None
        request = self._plan_request(plan.start, plan.goal, marks)
        call = next(self._ids)
        self._inflight = (call, "plan", time.monotonic(), plan, observation)
        client.call_async(request).add_done_callback(lambda future: self._on_planned(call, future))

    def _plan_around(self, observation: Observation, decision: Decision, marks: np.ndarray) -> None:
        """The traffic rules' replan around marks: a ~/plan with them as obstacles; the path adopted, or the
        observation answered as decided (held by its speed limit of 0)."""
        client = self._service_clients["plan"]
        if not client.service_is_ready() or self.navigator.goal is None:
            self.traffic.replanned_around(marks, False)
            self._finish(observation, decision)
            return
        request = self._plan_request(observation.pose[:2], self.navigator.goal, marks)
        call = next(self._ids)
        self._inflight = (call, "around", time.monotonic(), (decision, marks), observation)
        client.call_async(request).add_done_callback(lambda future: self._on_planned_around(call, future))

    def _on_planned_around(self, call: int, future) -> None:
        if self._inflight is None or self._inflight[0] != call:
            return
        _, _, _, (decision, marks), observation = self._inflight
        self._inflight = None
        try:
            response = future.result()
            success, problem = bool(response.success and response.path.poses), response.message
        except Exception as error:
            response, success, problem = None, False, f"~/plan failed: {error!r}"
        self._planned_around(observation, decision, marks, response.path if success else None, problem)

    def _planned_around(self, observation, decision: Decision, marks, path: Path | None, problem: str) -> None:
        if not self.active:
            return
        self.traffic.replanned_around(marks, path is not None)
        if path is None:
            self._log([f"no way around the obstacle: {problem}"])
            self._finish(observation, decision)
            return
        self._carry_out(observation, self.navigator.adopt(path_points(path), "around an obstacle not on the map"))

    def _on_planned(self, call: int, future) -> None:
        if self._inflight is None or self._inflight[0] != call:
            return  # timed out, or the node was deactivated meanwhile
        _, _, _, plan, observation = self._inflight
        self._inflight = None
        try:
            response = future.result()
        except Exception as error:
            self._planned(observation, plan, None, f"~/plan failed: {error!r}", False)
            return
        if response.success and response.path.poses:
            self._planned(observation, plan, response.path, "", False)
        else:
            self._planned(observation, plan, None, response.message or "no path", response.goal_refused)

    def _planned(self, observation, plan: PlanRequest, path: Path | None, error: str, goal_refused: bool) -> None:
        if not self.active:
            return
        points = None if path is None else path_points(path)
        decision = self.navigator.planned(plan, points, error, goal_refused)
        self._carry_out(observation, decision)

    def _hand_over(self, observation: Observation | None, decision: Decision) -> None:
        client = self._service_clients["follow"]
        path = path_message(decision.path, self._values["global_frame"], self.get_clock().now().to_msg())
        if not client.service_is_ready():
            self._handed_over(observation, decision, path, f"{client.srv_name} is not available")
            return
        call = next(self._ids)
        self._inflight = (call, "follow", time.monotonic(), (decision, path), observation)
        client.call_async(FollowPath.Request(path=path)).add_done_callback(
            lambda future: self._on_handed_over(call, future)
        )

    def _on_handed_over(self, call: int, future) -> None:
        if self._inflight is None or self._inflight[0] != call:
            return
        _, _, _, (decision, path), observation = self._inflight
        self._inflight = None
        try:
            response = future.result()
            problem = "" if response.success else response.message or "refused"
        except Exception as error:
            problem = f"~/follow_path failed: {error!r}"
        self._handed_over(observation, decision, path, problem)

    def _handed_over(self, observation, decision: Decision, path: Path, problem: str) -> None:
        if not self.active:
            return
        if problem:
            decision = self.navigator.path_refused(problem)
            self._log(decision.events)
        else:
            self._outputs["path"].publish(path)
        self._finish(observation, decision)

    def _finish(self, observation: Observation | None, decision: Decision) -> None:
        """Publish the decision for its observation, then go on with what waited meanwhile."""
        if observation is not None and observation.on_route:
            decision = self._on_route_limited(observation, decision)
        elif observation is not None and self.traffic is not None:
            decision = self._traffic(observation, decision)
            if decision is None:
                return  # a request went out for this observation: finished when it is answered
        if observation is not None:
            self._publish_status(observation, decision)
            self._last, self._last_decided = (observation, decision), time.monotonic()
        if self._follower_request is not None:
            request, self._follower_request = self._follower_request, None
            self._carry_out(None, Decision(self.navigator.mode, Controller.NONE, plan=request))
        elif self._pending is not None:
            pending, self._pending = self._pending, None
            self._decide(pending)

    def _traffic(self, observation: Observation, decision: Decision) -> Decision | None:
        """The traffic rules on one observation, as NavigationLoop.step applies them: the decision to publish
        (with its speed limit sent first), or None when a request (a detour handed over, a plan around marks)
        went out and will finish the observation."""
        traffic, navigator = self.traffic, self.navigator
        stamp_ns = stamp_nanoseconds(observation.stamp)
        stamp = stamp_ns * 1e-9
        if self._advised is not None and self._advised[0] == stamp_ns:  # advised already (a detour since)
            return self._limited(observation, decision, self._advised[1])
        self.board.prune(self.get_clock().now().nanoseconds * 1e-9)
        costmap = self._map_planner.costmap if self._map_planner is not None else None
        scan = scan_data(self._scan) if self._scan is not None else None
        if costmap is None or scan is None:  # the rules need the map and a scan: hold until both came
            if decision.controller is Controller.PATH_FOLLOWER or decision.mode is Mode.REACHED:
                self.get_logger().warning("traffic rules without /map or scan yet: holding", throttle_duration_sec=2.0)
                return self._limited(observation, decision, 0.0)
            traffic.post_idle(None, False)
            return self._posted(decision)
        if decision.controller is not Controller.PATH_FOLLOWER:
            advice = idle_advice(traffic, decision, observation.pose, costmap, stamp)
            if advice is None:
                self._posted(decision)
                if decision.mode is Mode.REACHED:  # held at its goal by the path follower: the world goes on
                    return self._limited(observation, decision, 0.0)
                return decision
            self._log(advice.events)
            self._carry_out(observation, navigator.detour(advice.detour, "going aside"))
            return None
        advice = traffic.advise(
            observation.pose, scan, navigator.followed_path, costmap, self._values["follower_speed"], stamp
        )
        self._log(advice.events)
        self._posted(decision)
        if advice.hold:
            return self._limited(observation, decision, 0.0)
        if advice.replan:
            navigator.plan_again("traffic: plan to the goal again")
            self._log(navigator.take_events())
            self._reports_after = stamp_ns
            return self._limited(observation, decision, 0.0)
        self._advised = (stamp_ns, advice.speed_limit)
        if advice.detour is not None:
            self._carry_out(observation, navigator.detour(advice.detour, "going aside"))
            return None
        if advice.replan_around is not None:
            self._plan_around(observation, decision, advice.replan_around)
            return None
        return self._limited(observation, decision, advice.speed_limit)

    def _on_route_limited(self, observation: Observation, decision: Decision) -> Decision:
        """An observation on the fleet route: posted on /traffic (the pose driven by and the path), the path follower
        named for it, with a speed limit of 0 while holding or at the goal, none otherwise."""
        path = self.navigator.followed_path
        self.board.post(
            TrafficPost(
                self.traffic.name,
                self.traffic.priority,
                observation.pose,
                path,
                "",
                (),
                decision.mode is Mode.REACHED,
                False,
            )
        )
        self._posted(decision)
        hold = decision.mode is Mode.REACHED or self._route is None or self._route.state == HOLD
        return self._limited(observation, replace(decision, controller=Controller.PATH_FOLLOWER), 0.0 if hold else None)

    def _limited(self, observation: Observation, decision: Decision, limit: float | None) -> Decision:
        """The decision with the path follower named and `limit` sent for its observation (a robot at its goal
        is held by the path follower with 0)."""
        self._advised = (stamp_nanoseconds(observation.stamp), limit)
        self._outputs["speed_limit"].publish(
            speed_limit_message(limit, observation.stamp, self._values["global_frame"])
        )
        if decision.controller is Controller.NONE and self.path_follower_has_path():
            return Decision(decision.mode, Controller.PATH_FOLLOWER, None, None, decision.reason, ())
        return decision

    def path_follower_has_path(self) -> bool:
        return self.navigator.followed_path is not None

    def _posted(self, decision: Decision) -> Decision:
        """Publish this robot's latest post (what the rules just put on the board) on /traffic, unless it says what
        the last one published did (same_post: within POST_MOVE and POST_TURN) and that one is younger than
        POST_KEEP_ALIVE (issue 36: every post wakes every other navigator; most robots of a fleet stand, wait or
        explore, so most posts said nothing new)."""
        post = self.board.get(self.traffic.name)
        if post is not None:
            now = self.get_clock().now()
            last = self._last_post
            if last is not None and same_post(last[0], post) and 0 <= now.nanoseconds - last[1] < POST_KEEP_ALIVE:
                return decision
            try:
                self._outputs["traffic"].publish(post_message(post, now.to_msg(), self._values["global_frame"]))
                self._last_post = (post, now.nanoseconds)
            except PostError as error:  # never a NaN on /traffic
                self.get_logger().error(f"own traffic post not sent: {error}", throttle_duration_sec=2.0)
        return decision

    def _check_inflight(self) -> None:
        """A request the planner or the path follower did not answer within plan_timeout has failed; an
        observation held for want of a path is tried again every RETRY_PERIOD."""
        now = time.monotonic()
        if self._inflight is None:
            held = self._last is not None and self._last[1].mode is Mode.NO_PATH and not self.navigator.goal_refused
            if held and now - self._last_decided >= RETRY_PERIOD:
                self._decide(self._last[0])
            return
        if now - self._inflight[2] <= self._values["plan_timeout"]:
            return
        call, kind, _, payload, observation = self._inflight
        self._inflight = None
        problem = f"no answer within {self._values['plan_timeout']} s"
        if kind == "plan":
            self._planned(observation, payload, None, f"{self._service_clients['plan'].srv_name}: {problem}", False)
        elif kind == "around":
            self._planned_around(observation, payload[0], payload[1], None, problem)
        else:
            self._handed_over(
                observation, payload[0], payload[1], f"{self._service_clients['follow'].srv_name}: {problem}"
            )

    # -- outputs ----------------------------------------------------------------------------------

    def _controller_name(self, controller: Controller) -> str:
        return {
            Controller.WALL_FOLLOWER: self._values["wall_follower"],
            Controller.PATH_FOLLOWER: self._values["path_follower"],
        }.get(controller, "")

    def _publish_status(self, observation: Observation, decision: Decision) -> None:
        navigator = self.navigator
        status = NavigatorStatus(
            mode=decision.mode.value,
            controller=self._controller_name(decision.controller),
            reason=decision.reason,
            localized=observation.localized,
            has_goal=navigator.goal is not None,
            plans=navigator.counters.plans,
            planning_failures=len(navigator.counters.planning_failures),
        )
        status.header.stamp, status.header.frame_id = observation.stamp, self._values["global_frame"]
        status.pose = self._pose_message(observation.pose)
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
            if event.startswith(("no path", "path refused", "replanning for the path follower failed")):
                self.get_logger().warning(event)
            else:
                self.get_logger().info(event)


def main(args=None) -> None:
    run(NavigatorNode, args=args)


if __name__ == "__main__":
    main()
