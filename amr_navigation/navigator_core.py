"""The navigator's core: one observation in, the decision and its effects out, with no ROS.

`NavigatorCore` is everything that decides for one robot: the `Navigator`'s modes (who drives, when to plan),
the localizer's confidence turned into "sure enough to drive a path" (`ConfidenceGate`), the traffic rules among
robots (amr_navigation.traffic), and following a fleet planner's route (coordination "plan": the paths through the
waypoints handed over, holds, the pose to drive by while the localizer is unsure). Two executors run it and decide
nothing themselves:

- the `navigator` node (amr_navigation.navigator_node) turns messages into `Observation`s and the effects into
  service calls and publications;
- the library loop (amr_navigation.loop.NavigationLoop) carries the effects out with the planner and controller
  objects in process.

`step(observation)` and `report(follower_report)` return a job: a generator that yields the calls whose answers
the decision needs, in order, and returns an `Outcome`:

- `PlanCall` (plan from start to goal, around `marks` if any): answered with a `PlanAnswer`. Every path the core
  drives is asked for this way (to the goal, around the traffic rules' marks, each leg through a fleet route's
  waypoints): the planner (the node's ~/plan, the loop's Planner) is the robot's one planner, and the core holds
  none;
- `HandOverCall` (give the path follower this path before it drives): answered with "" (taken) or the reason
  it was refused.

The `Outcome` holds the rest: the decision to publish (mode, the controller that answers the observation, the
reason), the pose decided on (on a route: the pose driven by), the speed limit for this observation (traffic),
whether this robot's traffic post changed, and the events to log. A library executor answers each call at once
(`run_job`); the node answers asynchronously and sends each answer in when it comes.

The confidence: the localizer's /pose carries the posterior probability of its best place. The
navigator drives a path once that reaches `drive_confidence`, and goes on driving it until it falls under
`release_confidence` (its own hysteresis, below the localizer's own withdrawal: a short dip of the localizer's
`localized` does not hand the robot to the wall follower and back). A localizer that gives no probability (a
localized /pose with confidence 0, as a relay of the ground truth sends) counts as 1 while localized.
"""

from __future__ import annotations

import math
from collections.abc import Generator
from dataclasses import dataclass, replace

import numpy as np

from amr_navigation.fleet_coordinator import HOLD, NONE, Route
from amr_navigation.fleet_schedule import STOPPED_SHORT, DeadReckoning, HandOver
from amr_navigation.navigator import Controller, Decision, Mode, Navigator, PlanRequest
from amr_navigation.traffic import Traffic
from amr_navigation.traffic_board import TrafficPost
from amr_navigation.traffic_steps import detour_done, idle_advice
from amr_planning.costmap import Costmap
from amr_util.geometry import compose, relative_pose
from amr_util.scan import ScanData

DEFAULT_DRIVE_CONFIDENCE = 0.95
"""the localizer's confidence at which the navigator drives a path (the particle filter declares localized at the
same probability)."""
DEFAULT_RELEASE_CONFIDENCE = 0.5
"""... and under which it stops (the best place no longer holds most of the belief)."""
DEFAULT_FOLLOWER_SPEED = 0.2
"""m/s: the path follower's linear_speed (the traffic rules' slow-down ramps up to it)."""
STOPPED_SHORT_STATES = tuple(state.value for state in STOPPED_SHORT)


@dataclass(frozen=True)
class Observation:
    """One observation as the navigator sees it (times in s)."""

    stamp: float
    pose: tuple[float, float, float]
    """the localizer's estimate in the map frame."""
    localized: bool
    """the localizer's own verdict."""
    confidence: float | None = None
    """the posterior probability of the best place (0..1); None: the localizer gives none (1 while localized)."""
    odometry: tuple[float, float, float] | None = None
    """the odometry pose of the same observation (what the pose to drive by moves on with while unsure, on a route)."""
    scan: ScanData | None = None
    """the scan of the observation (the traffic rules need it)."""


@dataclass(frozen=True)
class PlanCall:
    """Plan from start to goal on the map (around `marks`, discs of `mark_radius`, when given)."""

    start: tuple[float, float]
    goal: tuple[float, float]
    marks: np.ndarray | None = None
    mark_radius: float = 0.0


@dataclass(frozen=True)
class PlanAnswer:
    path: np.ndarray | None
    """(N, 2), or None: no path (error says why; goal_refused: the planner refused the goal itself)."""
    error: str = ""
    goal_refused: bool = False


@dataclass(frozen=True)
class HandOverCall:
    """Give the path follower this path before it drives (answered with '' or the reason it refused it)."""

    path: np.ndarray


Call = PlanCall | HandOverCall


@dataclass(frozen=True)
class FollowerReport:
    """The path follower's report on a command it computed for the observation stamped `stamp`."""

    stamp: float
    reached: bool
    replan: bool
    why: str = ""
    state: str = ""
    """its State's value (BLOCKED and STRAYED: stopped short)."""


@dataclass(frozen=True)
class Outcome:
    """What a job ends with."""

    decision: Decision | None
    """the decision to publish for the observation (None: a follower's report, nothing to publish)."""
    pose: tuple[float, float, float] | None = None
    """the pose decided on (on a route: the pose driven by, which the path follower drives from when unsure)."""
    limited: bool = False
    """a speed limit goes out for this observation (traffic rules)..."""
    speed_limit: float | None = None
    """... this one (m/s; None: none; 0: stand)."""
    post: bool = False
    """this robot's post on the traffic board is current: publish it."""
    events: tuple[str, ...] = ()
    """what happened, for the log."""
    detour_end: bool = False
    """(a report) the path follower reached the end of a detour: the rules wait there."""
    confidence: float = 0.0
    """(an observation) the localizer's confidence as the gate read it (ConfidenceGate.confidence)..."""
    confident: bool = False
    """... and the gate's verdict: sure enough to drive a path (what ~/status says, and the fleet planner waits for)."""


Job = Generator[Call, object, Outcome]


def run_job(job: Job, answer) -> Outcome:
    """Run a job to its end, each call answered at once by `answer(call)` (the library's executor)."""
    try:
        call = next(job)
        while True:
            call = job.send(answer(call))
    except StopIteration as stop:
        return stop.value


class ConfidenceGate:
    """Sure enough to drive a path: the confidence reaches `drive` and stays at or above `release`."""

    def __init__(self, drive: float = DEFAULT_DRIVE_CONFIDENCE, release: float = DEFAULT_RELEASE_CONFIDENCE) -> None:
        self.sure = False
        self.set(drive, release)

    def set(self, drive: float, release: float) -> None:
        for name, value in (("drive_confidence", drive), ("release_confidence", release)):
            if not (math.isfinite(value) and 0.0 <= value <= 1.0):
                raise ValueError(f"{name}: must be a probability in [0, 1], got {value!r}")
        if release > drive:
            raise ValueError(f"release_confidence: must be <= drive_confidence ({drive}), got {release}")
        self.drive, self.release = float(drive), float(release)

    @staticmethod
    def confidence(localized: bool, confidence: float | None) -> float:
        """The confidence of an observation: a localized one without a probability (None, or 0) counts as 1."""
        if confidence is None or not math.isfinite(confidence) or (localized and confidence <= 0.0):
            return 1.0 if localized else 0.0
        return float(confidence)

    def peek(self, localized: bool, confidence: float | None) -> bool:
        """Whether this observation would be sure (nothing changes)."""
        value = self.confidence(localized, confidence)
        return value >= (self.release if self.sure else self.drive)

    def update(self, localized: bool, confidence: float | None) -> bool:
        self.sure = self.peek(localized, confidence)
        return self.sure


class NavigatorCore:
    """All the decisions of one robot's navigator; see the module docstring."""

    def __init__(
        self,
        navigator: Navigator,
        *,
        traffic: Traffic | None = None,
        follower_speed: float = DEFAULT_FOLLOWER_SPEED,
        drive_confidence: float = DEFAULT_DRIVE_CONFIDENCE,
        release_confidence: float = DEFAULT_RELEASE_CONFIDENCE,
    ) -> None:
        self.navigator = navigator
        self.traffic = traffic
        """the traffic rules among other robots; None: a robot alone."""
        self.follower_speed = float(follower_speed)
        self.gate = ConfidenceGate(drive_confidence, release_confidence)
        self.costmap: Costmap | None = None
        """the map's costmap, read by the traffic rules' geometry (places aside, what is unmapped) and never planned
        on but for a detour aside on a marked copy; the planner's own (shared_costmap); None until a map."""
        self.route: Route | None = None
        """the fleet planner's latest HOLD or FOLLOW for this robot (None: the robot's own planning)."""
        self._hand_over_due = HandOver()
        self._reckoning = DeadReckoning()
        self._route_handed_at = -math.inf
        """s: the observation the route's path was handed over at (earlier reports are of an older path)."""
        self._follower_blocked = False
        self._reports_after = -math.inf
        """s: the path follower's reports up to this observation are of a path the traffic rules dropped."""
        self._warned: set[str] = set()

    def restart(self) -> None:
        """Forget the route and what following it kept (the navigator's goal and paths stay): a node reactivated."""
        self.route = None
        self._hand_over_due.reset()
        self._reckoning = DeadReckoning()
        self._route_handed_at = self._reports_after = -math.inf
        self._follower_blocked = False

    # -- inputs between observations -------------------------------------------------------------------

    def set_map(self, costmap: Costmap | None) -> None:
        self.costmap = costmap
        if costmap is not None:
            self._warned.clear()

    def set_goal(self, goal: tuple[float, float]) -> tuple[str, ...]:
        """A new goal (ValueError if not finite): the events."""
        self.navigator.set_goal(goal)
        return self.navigator.take_events()

    def set_route(self, route: Route | None) -> tuple[str, ...]:
        """The fleet planner's word (NONE or None: the robot's own planning again): the events."""
        before, self.route = self.route, (None if route is None or route.state == NONE else route)
        if self.route is None:
            events: tuple[str, ...] = ()
            if before is not None:  # back to its own planning: to the goal anew
                reason = route.reason if route is not None and route.reason else "withdrawn"
                self.navigator.plan_again(f"no fleet plan ({reason}): by the traffic rules")
                events = self.navigator.take_events()
            self._hand_over_due.reset()
            return events
        if before is None or before.plan != route.plan:
            return (f"fleet plan {route.plan}: {route.state}" + (f" ({route.reason})" if route.reason else ""),)
        return ()

    def driving_pose(
        self,
        pose: tuple[float, float, float],
        localized: bool,
        odometry: tuple[float, float, float] | None,
        confidence: float | None = None,
    ) -> tuple[float, float, float]:
        """The pose a robot on a route drives by for this observation, without taking it: the estimate while sure,
        else the last sure estimate moved on by odometry (DeadReckoning)."""
        pose = tuple(float(v) for v in pose)
        if odometry is None or self.gate.peek(localized, confidence) or self._reckoning.sure is None:
            return pose
        last, then = self._reckoning.sure
        return tuple(float(v) for v in compose(last, relative_pose(then, tuple(odometry))))

    # -- one observation ------------------------------------------------------------------------------

    def step(self, observation: Observation) -> Job:
        """The job for one observation: its calls, then its Outcome (with the gate's confidence and verdict)."""
        sure = self.gate.update(observation.localized, observation.confidence)
        outcome = yield from self._decide(observation, sure)
        confidence = self.gate.confidence(observation.localized, observation.confidence)
        return replace(outcome, confidence=confidence, confident=sure)

    def _decide(self, observation: Observation, sure: bool) -> Job:
        events: list[str] = []
        pose = tuple(float(v) for v in observation.pose)
        driving = pose
        if observation.odometry is not None:  # every observation: the last sure estimate is kept
            driving = self._reckoning.pose(pose, sure, observation.odometry)
        if self.route is not None and observation.stamp > self.route.expires:
            events.append(  # the fleet planner is silent (gone, or still planning): plan alone
                f"fleet route of plan {self.route.plan} expired at {self.route.expires:.2f} s: by the traffic rules "
                "until a new one"
            )
            self.route = None
            self.navigator.plan_again("the fleet route expired: by the traffic rules")
            events += self.navigator.take_events()
            self._hand_over_due.reset()
        if self.route is not None:
            return (yield from self._on_route(observation, driving, events))
        decision = yield from self._carry_out(self.navigator.decide(pose, sure), events)
        if self.traffic is None:
            return Outcome(decision, pose, events=tuple(events))
        return (yield from self._traffic(observation, pose, decision, events))

    def report(self, report: FollowerReport) -> Outcome | Job:
        """The path follower's report: an Outcome (nothing to do but log), or the job of the plan it asked for."""
        navigator, traffic = self.navigator, self.traffic
        if self.route is not None:  # on the fleet route: blocked (retried by HandOver), and the goal reached
            if report.stamp >= self._route_handed_at:
                self._follower_blocked = report.state in STOPPED_SHORT_STATES
                if report.reached and self.route.final and not navigator.on_detour:
                    navigator.followed(True, False)
            return Outcome(None, events=navigator.take_events())
        if traffic is not None and report.stamp <= self._reports_after:
            return Outcome(None)  # about the path the rules just dropped: a plan is due
        if detour_done(traffic, navigator, report.reached, report.stamp):
            return Outcome(None, detour_end=True)  # at the place aside: the rules wait there
        if traffic is not None and report.reached and navigator.mode is Mode.REACHED:
            return Outcome(None)  # held at its goal by the path follower: arrival was already taken
        request = navigator.followed(report.reached, report.replan, report.why)
        events = list(navigator.take_events())
        if request is None:
            return Outcome(None, events=tuple(events))
        return self._follower_plan(request, events)

    # -- carrying decisions out -------------------------------------------------------------------------

    def _follower_plan(self, request: PlanRequest, events: list[str]) -> Job:
        yield from self._carry_out(Decision(self.navigator.mode, Controller.NONE, plan=request), events)
        return Outcome(None, events=tuple(events))

    def _carry_out(self, decision: Decision, events: list[str]) -> Generator[Call, object, Decision]:
        """Plan what the decision asks to, then hand its path over; the decision to act on."""
        events += decision.events
        while decision.plan is not None:
            request = decision.plan
            marks = self.traffic.marks if self.traffic is not None and len(self.traffic.marks) else None
            radius = self.traffic.config.mark_radius if marks is not None else 0.0
            answer = yield PlanCall(request.start, request.goal, marks, radius)
            decision = self.navigator.planned(request, answer.path, answer.error, answer.goal_refused)
            events += decision.events
        if decision.path is not None:
            problem = yield HandOverCall(decision.path)
            if problem:
                decision = self.navigator.path_refused(str(problem))
                events += decision.events
        return replace(decision, plan=None, events=())

    def _traffic(
        self, observation: Observation, pose, decision: Decision, events: list[str]
    ) -> Generator[Call, object, Outcome]:
        """The traffic rules on one observation: the advice carried out, the speed limit, the post."""
        traffic, navigator, stamp = self.traffic, self.navigator, observation.stamp
        costmap = self.costmap
        scan = observation.scan
        if costmap is None or scan is None:  # the rules need the map and a scan: hold until both came
            if decision.controller is Controller.PATH_FOLLOWER or decision.mode is Mode.REACHED:
                self._warn("traffic rules without a map or a scan yet: holding", events)
                return self._limited(pose, decision, 0.0, events)
            traffic.post_idle(None, False)
            return Outcome(decision, pose, post=True, events=tuple(events))
        if decision.controller is not Controller.PATH_FOLLOWER:
            advice = idle_advice(traffic, decision, pose, costmap, stamp)
            if advice is None:
                if decision.mode is Mode.REACHED:  # held at its goal by the path follower: the world goes on
                    return self._limited(pose, decision, 0.0, events)
                return Outcome(decision, pose, post=True, events=tuple(events))
            events += advice.events
            decision = yield from self._carry_out(navigator.detour(advice.detour, "going aside"), events)
            if decision.controller is not Controller.PATH_FOLLOWER:
                return Outcome(decision, pose, post=True, events=tuple(events))
        advice = traffic.advise(pose, scan, navigator.followed_path, costmap, self.follower_speed, stamp)
        events += advice.events
        if advice.hold:
            return self._limited(pose, decision, 0.0, events)
        if advice.replan:
            navigator.plan_again("traffic: plan to the goal again")
            events += navigator.take_events()
            self._reports_after = stamp
            return self._limited(pose, decision, 0.0, events)
        if advice.detour is not None:
            decision = yield from self._carry_out(navigator.detour(advice.detour, "going aside"), events)
        if advice.replan_around is not None:
            decision = yield from self._plan_around(pose, decision, advice.replan_around, events)
        return self._limited(pose, decision, advice.speed_limit, events)

    def _plan_around(self, pose, decision: Decision, marks: np.ndarray, events: list[str]):
        """Plan to the goal with `marks` (unmapped returns) as obstacles: the path adopted, or the decision kept."""
        goal = self.navigator.goal
        if goal is None:
            self.traffic.replanned_around(marks, False)
            return decision
        answer = yield PlanCall(
            (pose[0], pose[1]), goal, np.asarray(marks, dtype=float), self.traffic.config.mark_radius
        )
        self.traffic.replanned_around(marks, answer.path is not None)
        if answer.path is None:
            events.append(f"no way around the obstacle: {answer.error}")
            return decision
        adopted = self.navigator.adopt(answer.path, "around an obstacle not on the map")
        return (yield from self._carry_out(adopted, events))

    def _on_route(self, observation: Observation, driving, events: list[str]) -> Generator[Call, object, Outcome]:
        """One observation on the fleet route: hold (HOLD), or the path follower driven through the waypoints it may
        drive to now, a new path handed over whenever they change or BLOCKED_RETRY s after it was blocked."""
        route, navigator, stamp = self.route, self.navigator, observation.stamp
        if route.state == HOLD:
            decision = navigator.on_route(driving, "holding: the fleet is being planned")
            events += decision.events
        else:
            why = f"fleet plan {route.plan}: waypoint {route.progress} of {route.total}"
            key = (route.plan, route.progress, route.waypoints.tobytes())
            if not self._hand_over_due.due(key, self._follower_blocked, stamp):
                decision = navigator.on_route(driving, why)
                events += decision.events
            elif self.costmap is None:  # the planner's map, as the rules hold for it: hold until it came
                self._warn("fleet route without a map yet: holding", events)
                self._hand_over_due.reset()
                decision = navigator.on_route(driving, "holding: no map yet")
                events += decision.events
            else:
                path = yield from self._legs(np.vstack([driving[:2], route.waypoints]))
                self._route_handed_at, self._follower_blocked = stamp, False
                events += (navigator.adopt if route.final else navigator.detour)(path, why).events
                decision = yield from self._carry_out(replace(navigator.on_route(driving, why), path=path), events)
        if self.traffic is not None:  # posted with the pose driven by and the path
            self.traffic.board.post(
                TrafficPost(
                    self.traffic.name,
                    self.traffic.priority,
                    driving,
                    navigator.followed_path,
                    "",
                    (),
                    decision.mode is Mode.REACHED,
                    False,
                )
            )
        hold = decision.mode is Mode.REACHED or self.route is None or self.route.state == HOLD
        return Outcome(
            replace(decision, controller=Controller.PATH_FOLLOWER),
            driving,
            limited=True,
            speed_limit=0.0 if hold else None,
            post=self.traffic is not None,
            events=tuple(events),
        )

    @staticmethod
    def _legs(route: np.ndarray) -> Generator[Call, object, np.ndarray]:
        """The route (K, 2) as the planner's paths from each point to the next (clear of the walls as any planned path
        is, where a straight line from where the robot stands to its next waypoint would clip a corner): one PlanCall
        per leg; a straight leg where the planner gives none."""
        route = np.asarray(route, dtype=float)
        points = [route[:1]]
        for a, b in zip(route[:-1], route[1:], strict=True):
            answer = yield PlanCall((float(a[0]), float(a[1])), (float(b[0]), float(b[1])))
            leg = answer.path if answer.path is not None else np.array([a, b])
            points.append(np.asarray(leg, dtype=float)[1:])
        return np.concatenate(points)

    def _limited(self, pose, decision: Decision, limit: float | None, events: list[str]) -> Outcome:
        """The decision with `limit` for its observation; a robot nobody drives that has a path is held by the path
        follower (at its goal: it may have to make way, and the lockstep world goes on)."""
        if decision.controller is Controller.NONE and self.navigator.followed_path is not None:
            decision = Decision(decision.mode, Controller.PATH_FOLLOWER, None, None, decision.reason, ())
        return Outcome(decision, pose, limited=True, speed_limit=limit, post=True, events=tuple(events))

    def _warn(self, text: str, events: list[str]) -> None:
        """A warning said once (until the map comes)."""
        if text not in self._warned:
            self._warned.add(text)
            events.append(text)
