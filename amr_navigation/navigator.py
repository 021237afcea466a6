"""Explore, localize, plan, follow: the one place that decides who drives, as a plain class (no ROS).

`Navigator` holds the mode of one robot and decides, for each observation (the localizer's estimate
and whether it says localized), which controller answers it with a command, and when a path must be
planned. It calls nothing itself: it returns what it decided, and its caller does it, then reports back.
The `navigator` node (amr_navigation.navigator_node) does it through topics and services; the library
loop (amr_navigation.loop.NavigationLoop) does it with the controller and planner objects in process.
Both make the same decisions, because they are made here.

The decisions, observation by observation:

- not localized: EXPLORE, the wall follower drives (to localize); a path and the goal are kept;
- localized, no goal: IDLE, nobody drives (waiting for a goal);
- localized, the path follower reported the goal reached: REACHED, nobody drives until a new goal or a
  loss of localization (the robot was moved: once localized again the goal is pursued again);
- localized, a plan is due (a first goal, a new goal, the estimate more than `replan_distance` from the
  path last planned, or no path yet for this goal): a `PlanRequest` from the estimate to the goal; the
  caller plans, reports with `planned`, and gets the decision for this observation;
- localized with a path: FOLLOW, the path follower drives;
- localized, the goal cannot be planned to: NO_PATH, nobody drives, and `reason` says why. A goal the
  planner refuses as such (inside an obstacle, off the map) waits for a new goal; any other failure is
  tried again at the next localized observation. A failure for the goal being followed (a stray
  replan) keeps following the old path to that same goal; a failure for a new goal drops the old path:
  the robot never drives on to a goal it was told to leave.

The path follower's own reports (`followed`): REACHED ends the trip; a request for a new plan (blocked,
strayed) gives a `PlanRequest` from the estimate to the followed path's end; its answer replaces the
followed path but not the one the stray check measures against (the planner's ~/plan service does not
change the planner's own path either); a failed request keeps the old path.

Events (planned, localized, no path: why, ...) are returned once per change, for the caller to log:
a failure repeated observation after observation is reported once, not at every retry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from amr_planning.planner import distance_to_path

DEFAULT_REPLAN_DISTANCE = 0.25
"""m off the planned path at which the robot counts as strayed and a new plan is due."""


class Mode(StrEnum):
    EXPLORE = "EXPLORE"
    """not localized: the wall follower drives."""
    FOLLOW = "FOLLOW"
    """localized with a path: the path follower drives."""
    IDLE = "IDLE"
    """localized, no goal: nobody drives."""
    NO_PATH = "NO_PATH"
    """localized, the goal cannot be planned to: nobody drives (the reason says why)."""
    REACHED = "REACHED"
    """the path follower reached the goal: nobody drives until a new goal or a loss of localization."""
    PLANNING = "PLANNING"
    """a plan is being made for this observation (the node: the planner has not answered yet)."""


class Controller(StrEnum):
    """Who answers an observation with a command (the values are the controller nodes' default names)."""

    WALL_FOLLOWER = "wall_follower"
    PATH_FOLLOWER = "path_follower"
    NONE = ""


DRIVER = {Mode.EXPLORE: Controller.WALL_FOLLOWER, Mode.FOLLOW: Controller.PATH_FOLLOWER}
"""The one controller of each mode; every other mode has none."""


class Purpose(StrEnum):
    GOAL = "goal"
    """the navigator's own plan to its goal (first, new goal, strayed, retry): the stray check's reference."""
    FOLLOWER = "follower"
    """the path follower asked (blocked, strayed from its path): to the followed path's end."""


@dataclass(frozen=True)
class PlanRequest:
    start: tuple[float, float]
    goal: tuple[float, float]
    purpose: Purpose
    why: str
    """first plan, new goal, strayed 0.31 m, no path yet, the follower asked: blocked ..."""


@dataclass(frozen=True)
class Decision:
    """What to do with one observation."""

    mode: Mode
    controller: Controller
    plan: PlanRequest | None = None
    """plan this first, then report with Navigator.planned(), which gives the decision to act on."""
    path: np.ndarray | None = None
    """a new path for the path follower, to hand over before it drives (None: keep the one it has)."""
    reason: str = ""
    """why nobody drives, or what is being done (the status line)."""
    events: tuple[str, ...] = ()
    """what changed at this observation, each said once (for the log)."""


@dataclass
class NavigatorCounters:
    plans: int = 0
    """paths planned and handed over (first plan, goal changes, strays, the follower's requests)."""
    planning_failures: list[str] = field(default_factory=list)
    """every failed plan's reason, retries included."""
    localization_losses: int = 0


class Navigator:
    """The mode of one robot and the decisions around it; see the module docstring."""

    def __init__(
        self, goal: tuple[float, float] | None = None, replan_distance: float = DEFAULT_REPLAN_DISTANCE
    ) -> None:
        if not (math.isfinite(replan_distance) and replan_distance > 0.0):
            raise ValueError(f"replan_distance: must be a positive number of metres, got {replan_distance!r}")
        self.replan_distance = float(replan_distance)
        self.goal: tuple[float, float] | None = None
        self.planned_path: np.ndarray | None = None
        """the navigator's own path to the goal (what the stray check measures against)."""
        self.followed_path: np.ndarray | None = None
        """the path the path follower follows (the navigator's, or a follower request's answer)."""
        self.counters = NavigatorCounters()
        self.mode = Mode.IDLE
        self.reason = ""
        self.pose: tuple[float, float, float] | None = None
        """the last estimate decided on."""
        self._planned_goal: tuple[float, float] | None = None
        self._followed_goal: tuple[float, float] | None = None
        self._reached_goal: tuple[float, float] | None = None
        self._refused_goal: tuple[float, float] | None = None
        self._localized = False
        self._detour = False
        """following a detour (going aside for another robot): not a stray, and its end is not the goal."""
        self._said: set[str] = set()
        self._events: list[str] = []
        if goal is not None:
            self.set_goal(goal)

    # -- inputs ---------------------------------------------------------------------------------

    def set_goal(self, goal: tuple[float, float]) -> None:
        """A new goal (any time: before or after arrival); planned for at the next localized observation."""
        x, y = (float(goal[0]), float(goal[1]))
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"goal: must be two finite numbers, got {goal!r}")
        if (x, y) != self.goal:
            self._say(f"new goal ({x:.2f}, {y:.2f})")
        self.goal = (x, y)
        self._reached_goal = self._refused_goal = None
        self._said.clear()

    def decide(self, pose: tuple[float, float, float], localized: bool) -> Decision:
        """The decision for one observation (the estimate in the map frame, and whether it says localized)."""
        self.pose = tuple(float(v) for v in pose)
        if localized != self._localized:
            if not localized:
                self.counters.localization_losses += 1
                if self._reached_goal is not None:  # moved after arrival (kidnapped, a reset): a new trip, planned anew
                    self._reached_goal = self.planned_path = None
            self._say("localized" if localized else "localization withdrawn: exploring again", once=False)
            self._localized = localized
        if not localized:
            return self._decision(Mode.EXPLORE, "exploring until localized")
        if self.goal is None:
            return self._decision(Mode.IDLE, "localized; no goal: waiting for one")
        if self._reached_goal == self.goal:
            return self._decision(Mode.REACHED, f"goal ({self.goal[0]:.2f}, {self.goal[1]:.2f}) reached")
        if self._refused_goal == self.goal:
            return self._decision(Mode.NO_PATH, self.reason)
        why = self._plan_due(self.pose[0], self.pose[1])
        if why:
            request = PlanRequest((self.pose[0], self.pose[1]), self.goal, Purpose.GOAL, why)
            return self._decision(Mode.PLANNING, f"planning ({why})", plan=request)
        return self._drive()

    def planned(
        self, request: PlanRequest, path: np.ndarray | None, error: str = "", goal_refused: bool = False
    ) -> Decision:
        """The answer to a PlanRequest: a path (N, 2), or None with the planner's reason (and whether the
        planner refused the goal itself). Returns the decision for the observation that asked."""
        if path is not None:
            path = np.asarray(path, dtype=float)
        if request.purpose is Purpose.FOLLOWER:
            if self.followed_path is None or self._followed_goal != self.goal:
                return self._drive()  # the trip it was asked for is over (a new goal, a dropped path)
            if path is None:
                self.counters.planning_failures.append(error)
                self._say(f"replanning for the path follower failed: {error}")
                return self._drive()
            self.counters.plans += 1
            self.followed_path = path
            self._say(f"replanned on the follower's request ({len(path)} points)", once=False)
            return self._drive(path)
        if request.goal != self.goal:  # the goal changed while planning: decide this observation again
            return self.decide(self.pose, True)
        self._planned_goal = request.goal
        if path is None:
            self.planned_path = None
            self.counters.planning_failures.append(error)
            if self._followed_goal != self.goal:  # never drive on to a goal that was left
                self.followed_path = self._followed_goal = None
            if goal_refused:
                self._refused_goal = self.goal
            self.reason = f"no path to ({self.goal[0]:.2f}, {self.goal[1]:.2f}): {error}"
            self._say(self.reason)
            return self._drive()
        self.counters.plans += 1
        self.planned_path = self.followed_path = path
        self._followed_goal = self.goal
        self._detour = False
        self._said = {said for said in self._said if not said.startswith("no path")}
        self._say(f"planned {len(path)} points to ({self.goal[0]:.2f}, {self.goal[1]:.2f}) ({request.why})", once=False)
        return self._drive(path)

    def path_refused(self, error: str) -> Decision:
        """The path follower refused the path it was handed (PathError): nobody follows it."""
        self.followed_path = self._followed_goal = None
        self.reason = f"path refused by the path follower: {error}"
        self._say(self.reason)
        return self._drive()

    def followed(self, reached: bool, replan: bool, why: str = "") -> PlanRequest | None:
        """The path follower's report on a command it computed: the goal reached, or a new plan wanted."""
        if self._detour:
            reached = False  # the end of a detour is not the goal
        if reached and self.goal is not None and self._followed_goal == self.goal:
            if self._reached_goal != self.goal:
                self._say(f"goal ({self.goal[0]:.2f}, {self.goal[1]:.2f}) reached", once=False)
            self._reached_goal = self.goal
            return None
        if replan and self.followed_path is not None and self.pose is not None:
            end = self.followed_path[-1]
            return PlanRequest(
                (self.pose[0], self.pose[1]),
                (float(end[0]), float(end[1])),
                Purpose.FOLLOWER,
                f"the follower asked: {why}" if why else "the follower asked",
            )
        return None

    # -- traffic (amr_navigation.traffic): unused by a robot alone ---------------------------------

    def adopt(self, path: np.ndarray, why: str) -> Decision:
        """A path to the goal planned by the caller (around obstacles the map does not hold): followed, and
        the stray check's reference from now on."""
        path = np.asarray(path, dtype=float)
        self.counters.plans += 1
        self.planned_path = self.followed_path = path
        self._followed_goal = self._planned_goal = self.goal
        self._detour = False
        self._say(f"planned {len(path)} points to the goal ({why})", once=False)
        return self._drive(path)

    def detour(self, path: np.ndarray, why: str) -> Decision:
        """Follow `path` for a while instead of the path to the goal (going aside for another robot): no stray
        check, its end is not the goal, and a goal reached is pursued again afterwards (plan_again)."""
        path = np.asarray(path, dtype=float)
        self.followed_path = path
        self._followed_goal = self.goal
        self._reached_goal = None
        self._detour = True
        self._say(why, once=False)
        return self._drive(path)

    def plan_again(self, why: str) -> None:
        """End a detour (or drop a path planned around obstacles): a plan to the goal is due at the next
        localized observation."""
        self.planned_path = None
        self._detour = False
        self._say(why, once=False)

    def on_route(self, pose: tuple[float, float, float], why: str) -> Decision:
        """Coordination by a fleet plan: the decision for an observation while the robot follows its route (the
        caller hands the paths over, with `adopt` for the last stretch to the goal and `detour` for any other):
        REACHED once the path follower reached the goal at the end of it, else the path follower drives (holding
        where the route ends)."""
        self.pose = tuple(float(v) for v in pose)
        if self.goal is not None and self._reached_goal == self.goal:
            return self._decision(Mode.REACHED, f"goal ({self.goal[0]:.2f}, {self.goal[1]:.2f}) reached")
        return self._decision(Mode.FOLLOW, why)

    @property
    def on_detour(self) -> bool:
        return self._detour

    @property
    def goal_refused(self) -> bool:
        """The planner refused the current goal itself: only a new goal can be planned to."""
        return self.goal is not None and self._refused_goal == self.goal

    def take_events(self) -> tuple[str, ...]:
        """What changed since the last call (decide/planned return them too)."""
        events, self._events = tuple(self._events), []
        return events

    # -- helpers --------------------------------------------------------------------------------

    def _plan_due(self, x: float, y: float) -> str:
        """Why a plan is due at (x, y), or ''."""
        if self._planned_goal != self.goal:
            return "new goal" if self._followed_goal is not None else "first plan"
        if self.planned_path is None:
            return "no path yet"
        if self._detour:
            return ""
        distance = distance_to_path(self.planned_path, x, y)
        if distance > self.replan_distance:
            self._say(
                f"strayed {distance:.2f} m from the planned path (more than {self.replan_distance} m): planning again",
                once=False,
            )
            return f"strayed {distance:.2f} m"
        return ""

    def _drive(self, path: np.ndarray | None = None) -> Decision:
        if self.followed_path is None:
            return self._decision(Mode.NO_PATH, self.reason or "no path")
        self.reason = ""
        return self._decision(Mode.FOLLOW, f"following {len(self.followed_path)} points", path=path)

    def _decision(
        self, mode: Mode, reason: str, *, plan: PlanRequest | None = None, path: np.ndarray | None = None
    ) -> Decision:
        self.mode = mode
        return Decision(mode, DRIVER.get(mode, Controller.NONE), plan, path, reason, self.take_events())

    def _say(self, event: str, once: bool = True) -> None:
        """Queue an event for the log; with once, only if it was not said since the last goal or success."""
        if once:
            if event in self._said:
                return
            self._said.add(event)
        self._events.append(event)
