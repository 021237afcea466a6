"""Who plans the fleet, when, and what each robot is told (the fleet_planner node's logic, no ROS).

The fleet_planner node (amr_navigation.fleet_planner_node) feeds a `FleetCoordinator` each robot's navigator status
as it comes (where the robot is, whether its localizer is sure, its goal) and the map's costmap, and publishes the
`Route`s it returns on each robot's fleet_route (amr_interfaces/FleetRoute):

- **NONE** until every robot's latest status says localized, with a goal, within `window` s of the others, and
  has said localized without a break for `settle_time` s: the navigators go by the traffic rules meanwhile (as
  run_fleet's coordination "plan" does at library level). A filter that has just declared may withdraw within a
  second (a rival place found: through ROS, `perfect 15`'s r2 declared 1.58 m off and withdrew 0.2 s later), and a
  plan made from that estimate sends the robot the wrong way.
- **HOLD** to every robot, then the plan: the lattice of the costmap (amr_planning.fleet_plan.lattice, `spacing`),
  each robot from a vertex of its own near where it stands to the one nearest its goal (fleet_plan.assign:
  the assignment of least squared way lengths, the way straight to a vertex the robot sees, then along the
  lattice; not each robot's nearest free vertex, which for the second of two robots in one maze cell may lie
  beyond a wall), `improve(plan_lacam(...))` with PLAN_SEEDS seeds, the plan that would end first kept
  (fleet_plan.execution_time: its robots driven at `follower_speed`, turning at `turn_rate`, each move as soon as its
  dependencies are done; not the makespan, which counts lockstep steps: in `perfect 9` the plan of 95 steps
  brought the last robot home at 308.5 s, the one of 112 steps timed shortest at 248.2 s).
- **FOLLOW**: each robot's waypoints it may drive to now (amr_navigation.fleet_schedule.Schedule.route from where
  it last said it stood), the last one its goal when `final`. Every status moves the schedule on
  (Schedule.report), and every robot whose span (progress, allowed) changed is told again.
- **Stuck**: a robot that may drive on but has not reached its next waypoint for `stuck_time` s (something not on
  the map in the way: its path follower stops for it, and tries again every second) has that waypoint's vertex
  cut off the lattice (every edge of it: a box on a vertex would block a way round that entered it from another
  side too), and the fleet is planned again at once from where the robots stand, the stuck robot from the vertex
  it came from if it stands within a spacing of it (else from where it stands, as the others; never from a vertex
  cut off) (HOLD, then the new routes; every robot drives by odometry where its localizer is unsure, so no
  localization is waited for). The cut edges stay cut until a new map, or until a plan cannot be made with them
  (in a tree maze a vertex cut off may be the only way to a goal): then they are restored and the fleet is planned
  on the whole lattice.
- **Jumped**: a robot whose status pose moves farther than half a spacing beyond what it could have driven since
  its last status (JUMP_SPEED) had its estimate moved by its localizer (withdrawn and declared again elsewhere):
  the plan assumed it was elsewhere, and the fleet is planned again at once from where the robots stand.
- A plan that cannot be made (robots on one goal vertex, no lattice, no solution) is NONE to everyone with the
  reason, and tried again `retry_period` s later. A robot's goal changed (its status's goal is not the plan's),
  a new map: the plan is dropped (NONE to everyone) and made again once every robot is localized.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from amr_control.path_follower import FollowCommand, PathError, PathFollower
from amr_navigation.fleet_schedule import STOPPED_SHORT, HandOver, Schedule, legs
from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError
from amr_planning.fleet_plan import Lattice, assign, execution_time, improve, lattice, plan_lacam
from amr_planning.planner import Planner
from amr_util.scan import ScanData

NONE, HOLD, FOLLOW = "NONE", "HOLD", "FOLLOW"
GOAL_TOLERANCE = 1e-6
"""m a status's goal may differ from the plan's before the goal counts as changed."""
PLAN_SEEDS = 4
"""LaCAM searches per plan (their seeds 1000 apart): the plan whose robots would all arrive first when driven by its
action dependencies (fleet_plan.execution_time), then of least makespan and cost, is kept."""
JUMP_SPEED = 1.0
"""m/s no robot of the fleet drives faster than (a TurtleBot3 Burger 0.22): a status pose moving faster jumped."""


@dataclass(frozen=True)
class Route:
    """What one robot is told (amr_interfaces/FleetRoute field for field)."""

    state: str
    waypoints: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    """(K, 2) with FOLLOW: the waypoints it may drive to now, in order."""
    final: bool = False
    plan: int = 0
    progress: int = 0
    total: int = 0
    reason: str = ""


@dataclass
class RobotStatus:
    stamp: float
    x: float
    y: float
    localized: bool
    goal: tuple[float, float] | None


class FleetCoordinator:
    """See the module docstring."""

    def __init__(
        self,
        names: list[str],
        spacing: float,
        *,
        window: float = 0.5,
        retry_period: float = 10.0,
        stuck_time: float = 15.0,
        settle_time: float = 3.0,
        follower_speed: float = 0.2,
        turn_rate: float = 1.0,
    ) -> None:
        if not names:
            raise ValueError("robots: the fleet has no robot")
        if len(set(names)) != len(names):
            raise ValueError(f"robots: a name is listed twice in {names}")
        if not (math.isfinite(spacing) and spacing > 0.0):
            raise ValueError(f"lattice_spacing: must be a positive number of metres, got {spacing!r}")
        if not (math.isfinite(settle_time) and settle_time >= 0.0):
            raise ValueError(f"settle_time: must be a number of seconds, 0 or more, got {settle_time!r}")
        for key, value in (("follower_speed", follower_speed), ("turn_rate", turn_rate)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{key}: must be a positive number, got {value!r}")
        self.names = list(names)
        self.spacing = float(spacing)
        self.window = float(window)
        self.retry_period = float(retry_period)
        self.stuck_time = float(stuck_time)
        self.settle_time = float(settle_time)
        self.follower_speed, self.turn_rate = float(follower_speed), float(turn_rate)
        """m/s and rad/s the plans are timed at (fleet_plan.execution_time), to keep the one that ends first."""
        self._localized_since: dict[str, float] = {}
        """per robot: the stamp of the first of its latest unbroken run of localized statuses."""
        self.cut: list[tuple[int, int]] = []
        """the lattice edges found blocked (cut until a new map)."""
        self.events: list[str] = []
        """what happened, for the log (taken by take_events)."""
        self._moving_since: list[float] = []
        """per robot: since when it has been allowed farther than its progress without its span changing."""
        self._replan = False
        """a stuck robot: plan again now, from where the robots stand."""
        self._restart: dict[int, int] = {}
        """a stuck robot -> the vertex it is planned again from (the one it came from, if it is near it)."""
        self.statuses: dict[str, RobotStatus] = {}
        self.schedule: Schedule | None = None
        self.plans = 0
        """plans made (the FleetRoute's plan number of the latest)."""
        self.failures: list[str] = []
        self.planning_time = 0.0
        """s (wall clock) the latest plan took."""
        self._costmap: Costmap | None = None
        self._lattice: Lattice | None = None
        self._goals: list[tuple[float, float]] = []
        self._told: dict[str, tuple] = {}
        """what each robot was last told (its span on the plan, or its state)."""
        self._retry_at = -math.inf

    @property
    def lattice_size(self) -> int:
        """points of the lattice planned on (0 before the first plan)."""
        return 0 if self._lattice is None else len(self._lattice)

    # -- inputs ---------------------------------------------------------------------------------------

    def set_costmap(self, costmap: Costmap) -> dict[str, Route]:
        """A new map's costmap (the lattice is made of it at the next plan); a plan in force is dropped."""
        self._costmap, self._lattice, self.cut, self._restart = costmap, None, [], {}
        return self.drop("a new map") if self.schedule is not None else {}

    def observe(
        self, name: str, stamp: float, x: float, y: float, localized: bool, goal: tuple[float, float] | None
    ) -> dict[str, Route]:
        """One robot's status (s, m, its goal or None): the routes that change, by robot name (ValueError for a
        robot not in the fleet or a pose that is not finite)."""
        if name not in self.names:
            raise ValueError(f"{name!r} is not a robot of the fleet ({', '.join(self.names)})")
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(stamp)):
            raise ValueError(f"{name}: status pose ({x}, {y}) at {stamp} is not finite")
        if goal is not None and not all(math.isfinite(v) for v in goal):
            goal = None
        before = self.statuses.get(name)
        if not localized:
            self._localized_since.pop(name, None)
        elif stamp < self._localized_since.get(name, math.inf):  # the first, or the clock went back
            self._localized_since[name] = float(stamp)
        self.statuses[name] = RobotStatus(
            float(stamp),
            float(x),
            float(y),
            bool(localized),
            None if goal is None else (float(goal[0]), float(goal[1])),
        )
        if self.schedule is None:
            return {}
        robot = self.names.index(name)
        planned = self._goals[robot]
        if goal is None or math.hypot(goal[0] - planned[0], goal[1] - planned[1]) > GOAL_TOLERANCE:
            return self.drop(f"{name}'s goal changed")
        if before is not None and self._jumped(before, self.statuses[name]):
            self.events.append(
                f"{name}'s pose jumped {math.hypot(x - before.x, y - before.y):.2f} m in "
                f"{stamp - before.stamp:.2f} s (its localizer moved its estimate): the fleet planned "
                "again from where the robots stand"
            )
            self.schedule, self._replan = None, True
            return {}
        if self.schedule.report(robot, x, y):
            return self._routes()
        if self.schedule.allowed(robot) == self.schedule.progress[robot]:
            self._moving_since[robot] = stamp  # waiting for others, as planned
        elif stamp - self._moving_since[robot] > self.stuck_time:
            self._stuck(robot)
        return {}

    # -- planning ---------------------------------------------------------------------------------------

    def plan_due(self) -> bool:
        """No plan in force, the costmap known, and every robot's latest status localized with a goal, all within
        `window` s of one another, each localized without a break for `settle_time` s (not before `retry_period` s
        after a failure)."""
        if self._replan and self.schedule is None and self._costmap is not None:
            return True
        if self.schedule is not None or self._costmap is None or len(self.statuses) < len(self.names):
            return False
        statuses = [self.statuses[name] for name in self.names]
        if not all(status.localized and status.goal is not None for status in statuses):
            return False
        stamps = [status.stamp for status in statuses]
        settled = all(
            status.stamp - self._localized_since[name] >= self.settle_time for name, status in zip(self.names, statuses)
        )
        return settled and max(stamps) - min(stamps) <= self.window and max(stamps) >= self._retry_at

    def hold(self) -> dict[str, Route]:
        """HOLD to every robot (while the plan is made)."""
        return self._tell(
            {name: Route(HOLD, plan=self.plans + 1, reason="the fleet is being planned") for name in self.names}
        )

    def plan(self) -> dict[str, Route]:
        """Plan the fleet from where the robots said they stand to their goals: every robot's route (FOLLOW), or
        NONE to every one with the reason when no plan could be made."""
        began = time.perf_counter()
        statuses = [self.statuses[name] for name in self.names]
        self._goals = [status.goal for status in statuses]
        self._replan = False
        try:
            if self._lattice is None:
                self._lattice = lattice(self._costmap, self.spacing)
            restart, self._restart = self._restart, {}
            try:
                plan = self._plan_on(self._lattice.without(self.cut), statuses, restart)
            except (PlanningError, ValueError) as error:
                if not self.cut:
                    raise
                # in a tree maze a vertex cut off may be the only way to a goal: the cuts were guesses at something
                # the map does not hold, and no plan at all is worse than meeting it again (the stuck rule stays)
                self.events.append(
                    f"no fleet plan with {len(self.cut)} lattice edges cut off ({error}): they are "
                    "restored, the fleet planned on the whole lattice"
                )
                self.cut = []
                plan = self._plan_on(self._lattice, statuses, restart)
        except (PlanningError, ValueError) as error:
            self.failures.append(str(error))
            self._retry_at = max(status.stamp for status in statuses) + self.retry_period
            return self._tell(
                {
                    name: Route(
                        NONE,
                        reason=f"no fleet plan: {error}; by the traffic rules, planning "
                        f"again in {self.retry_period:g} s",
                    )
                    for name in self.names
                }
            )
        finally:
            self.planning_time = time.perf_counter() - began
        self.plans += 1
        self.schedule = Schedule(plan, self._goals)
        self._moving_since = [max(status.stamp for status in statuses)] * len(self.names)
        return self._routes()

    def _plan_on(self, graph: Lattice, statuses: list, restart: dict[int, int]):
        """The fleet plan on `graph` from the robots' vertices (`restart`'s, else assigned to where they stand:
        amr_planning.fleet_plan.assign) to the vertices nearest their goals; PlanningError or ValueError when
        none is found."""
        moving = [robot for robot in range(len(statuses)) if robot not in restart]
        # a vertex whose every edge is cut is where a robot was stuck: no robot is planned from it
        blocked = [
            vertex for vertex in range(len(graph)) if not graph.neighbours[vertex] and self._lattice.neighbours[vertex]
        ]
        chosen = assign(
            graph,
            self._costmap,
            [(statuses[robot].x, statuses[robot].y) for robot in moving],
            taken=list(restart.values()) + blocked,
        )
        vertex_of = {**restart, **dict(zip(moving, chosen))}
        starts = [vertex_of[robot] for robot in range(len(statuses))]
        goals = [graph.nearest(*goal) for goal in self._goals]  # two goals on one vertex: too close, refused
        plans = [improve(plan_lacam(graph, starts, goals, seed=1000 * k)) for k in range(PLAN_SEEDS)]
        return min(
            plans,
            key=lambda plan: (execution_time(plan, self.follower_speed, self.turn_rate), plan.makespan, plan.cost),
        )

    def route(self, name: str) -> Route:
        """What `name` is told now by the plan in force (FOLLOW), NONE without one."""
        if self.schedule is None:
            return Route(NONE, reason="no fleet plan yet")
        schedule, robot = self.schedule, self.names.index(name)
        status = self.statuses[name]
        waypoints = schedule.route(robot, status.x, status.y)[1:]
        last = len(schedule.waypoints[robot]) - 1
        final = schedule.allowed(robot) == last and bool(np.allclose(waypoints[-1], schedule.waypoints[robot][last]))
        return Route(
            FOLLOW,
            waypoints,
            final,
            self.plans,
            schedule.progress[robot],
            last,
            f"{len(self.names)} robots, planned in {self.planning_time:.2f} s",
        )

    # -- helpers ----------------------------------------------------------------------------------------

    def _span(self, robot: int) -> tuple:
        return FOLLOW, self.plans, self.schedule.progress[robot], self.schedule.allowed(robot)

    def _routes(self) -> dict[str, Route]:
        """The FOLLOW routes whose span changed since the robot was last told (its stuck clock restarted)."""
        changed = {}
        for robot, name in enumerate(self.names):
            span = self._span(robot)
            if self._told.get(name) != span:
                self._told[name] = span
                self._moving_since[robot] = self.statuses[name].stamp
                changed[name] = self.route(name)
        return changed

    def _jumped(self, before: RobotStatus, now: RobotStatus) -> bool:
        """The status pose moved farther than half a spacing beyond JUMP_SPEED times the time between the two."""
        gap = max(0.0, now.stamp - before.stamp)
        return math.hypot(now.x - before.x, now.y - before.y) > 0.5 * self.spacing + JUMP_SPEED * gap

    def _stuck(self, robot: int) -> None:
        """The robot has not reached its next waypoint for stuck_time s: cut that vertex off, plan again now (the
        robot from the vertex it came from if it stands within a spacing of it: it may have been driven far from
        it, around something, by its path follower)."""
        vertices = self.schedule.plan.vertices(robot)
        progress = self.schedule.progress[robot]
        came_from, blocked = vertices[progress], vertices[progress + 1]
        self.cut += [(blocked, other) for other in self._lattice.neighbours[blocked]]
        status = self.statuses[self.names[robot]]
        x, y = self._lattice.points[came_from]
        if math.hypot(status.x - x, status.y - y) <= self.spacing:
            self._restart[robot] = came_from
        x, y = self._lattice.points[blocked]
        self.events.append(
            f"{self.names[robot]} has not reached its next waypoint ({x:.2f}, {y:.2f}) for "
            f"{self.stuck_time:g} s: that lattice vertex cut off ({len(self.cut)} edges cut), the fleet "
            "planned again from where the robots stand"
        )
        self.schedule, self._replan = None, True

    def take_events(self) -> list[str]:
        events, self.events = self.events, []
        return events

    def _tell(self, routes: dict[str, Route]) -> dict[str, Route]:
        for name, route in routes.items():
            self._told[name] = (route.state, route.plan)
        return routes

    def drop(self, why: str) -> dict[str, Route]:
        """Drop the plan in force (if any): NONE to every robot, with `why`."""
        self.schedule = None
        return self._tell(
            {
                name: Route(
                    NONE,
                    reason=f"the fleet plan was dropped: {why}; by the traffic rules "
                    "until every robot is localized again",
                )
                for name in self.names
            }
        )


class RouteDriver:
    """One robot's path follower driven along the route it was last told, at library level (the navigator node's
    coordination "plan" does the same through the path follower node): on FOLLOW the planner's `legs` from where it
    stands through the waypoints, handed over again when the route changes or BLOCKED_RETRY s after the follower
    stopped short (`HandOver`); on HOLD the follower stands (speed limit 0)."""

    def __init__(self, follower: PathFollower, planner: Planner) -> None:
        self.follower, self.planner = follower, planner
        self._hand_over = HandOver()

    def command(
        self, pose: tuple[float, float, float], scan: ScanData | None, stamp: float, route: Route
    ) -> FollowCommand:
        x, y, theta = pose
        if route.state == HOLD:
            return self.follower.compute(x, y, theta, scan, speed_limit=0.0)
        key = (route.plan, route.progress, route.waypoints.tobytes())
        if self._hand_over.due(key, self.follower.state in STOPPED_SHORT, stamp):
            try:
                self.follower.set_path(legs(self.planner, np.vstack([(x, y), route.waypoints])))
            except PathError:
                self.follower.clear()
        return self.follower.compute(x, y, theta, scan)
