"""Who plans the fleet, when, and what each robot is told (the fleet_planner node's logic, no ROS).

The fleet_planner node (amr_navigation.fleet_planner_node) feeds a `FleetCoordinator` each robot's navigator status
as it comes (where the robot is, whether its navigator is confident, its goal) and the map's costmap, and publishes
the `Route`s it returns on each robot's fleet_route (amr_interfaces/FleetRoute):

- **NONE** until every robot's latest status says confident, with a goal, all within `window` s of one another (a
  snapshot of the fleet, not one robot's word of long ago): the navigators go by the traffic rules meanwhile (as
  run_fleet's coordination "plan" does at library level). Confident is the navigator's own verdict
  (navigator_core.ConfidenceGate on the localizer's confidence: reached drive_confidence, not fallen under
  release_confidence since), the one it drives a path on; not the localizer's `localized`, whose withdrawals
  within a second of a declaration the former `settle_time` guard (each robot localized without a break for 3 s)
  waited out (bench/bench_fleet_confidence.py: docs/fleet.md).
- **HOLD** to every robot, then the plan: the lattice of the costmap (amr_planning.fleet_lattice.lattice, `spacing`),
  each robot from a vertex of its own near where it stands to the one nearest its goal (fleet_lattice.assign:
  the assignment of least squared way lengths, the way straight to a vertex the robot sees, then along the
  lattice; not each robot's nearest free vertex, which for the second of two robots in one maze cell may lie
  beyond a wall), `improve(plan_lacam(...))` with PLAN_SEEDS seeds, the plan that would end first kept
  (fleet_execution.execution_time: its robots driven at `follower_speed`, turning at `turn_rate`, each move as soon
  as its dependencies are done; not the makespan, which counts lockstep steps: in `perfect 9` the plan of 95 steps
  brought the last robot home at 308.5 s, the one of 112 steps timed shortest at 248.2 s).
- **FOLLOW**: each robot's waypoints it may drive to now (amr_navigation.fleet_schedule.Schedule.route from where
  it last said it stood), the last one its goal when `final`. Every status moves the schedule on
  (Schedule.report), and every robot whose span (progress, allowed) changed is told again.
- **Stuck**: a robot that may drive on but has not reached its next waypoint for `stuck_time` s (something not on
  the map in the way: its path follower stops for it, and tries again every second) has that waypoint's vertex
  cut off the lattice (every edge of it: a box on a vertex would block a way round that entered it from another
  side too), and the fleet is planned again at once from where the robots stand, the stuck robot from the vertex
  it came from if it stands within a spacing of it (else from where it stands, as the others; never from a vertex
  cut off) (HOLD, then the new routes; every robot drives by odometry where its navigator is not confident, so no
  localization is waited for). The cut edges stay cut until a new map, or until a plan cannot be made with them
  (in a tree maze a vertex cut off may be the only way to a goal): then they are restored and the fleet is planned
  on the whole lattice.
- **Jumped**: a robot whose status pose moves farther than half a spacing beyond what it could have driven since
  its last status (JUMP_SPEED) had its estimate moved by its localizer (another place became the best, or its
  navigator became confident again after driving by odometry): the plan assumed it was elsewhere, and the fleet is
  planned again at once from where the robots stand. The confidence does not make this unneeded: an estimate may
  move while it stays confident (the best place changing) and does when confidence comes back.
- **Partial replans.** A stuck or jumped robot does not hold the fleet: only the robots whose routes conflict
  (the robot itself, and any robot whose remaining way passes the vertex cut off) are planned again, each in
  priority order around the others' remaining ways (each kept robot's way timed by the plan's action
  dependencies, as early as they allow: `partial_plan`); the other robots drive on meanwhile and keep their
  waypoints. If no such plan exists the whole fleet is planned again from where it stands.
- **Off the caller's thread.** `begin_plan` takes what a plan needs (a `PlanJob`: the robots' statuses, the
  lattice, the cuts, the plan in force and its progress) and returns the HOLDs to send; `compute_plan(job)` (pure:
  any thread) makes the plan; `finish_plan(outcome)` adopts it (a kept robot's progress made meanwhile carried
  over) unless the plan was dropped or the map changed meanwhile. `plan()` is the three at once.
- **Expiry.** Every route is told with `expires` = its stamp + `route_lifetime` (statuses' clock): a navigator
  that hears nothing newer by then goes back to its own planning. `renewals(now)` re-tells each FOLLOW route
  halfway to its expiry; a HOLD is never renewed (a plan that takes longer than the lifetime lets the held robots
  go on by themselves until it comes).
- A plan that cannot be made (robots on one goal vertex, no lattice, no solution) is NONE to everyone with the
  reason, and tried again `retry_period` s later. A robot's goal changed (its status's goal is not the plan's),
  a new map: the plan is dropped (NONE to everyone) and made again once every robot is confident.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from amr_navigation.fleet_schedule import Schedule
from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError
from amr_planning.fleet_execution import dependencies, execution_time
from amr_planning.fleet_improve import improve
from amr_planning.fleet_lacam import plan_lacam
from amr_planning.fleet_lattice import Lattice, assign, lattice
from amr_planning.fleet_paths import FleetPlan, rotates, trim
from amr_planning.fleet_space_time import constraints_around as around  # one robot's constraints from the others
from amr_planning.fleet_space_time import space_time_path  # A* over (vertex, step) under those constraints

NONE, HOLD, FOLLOW = "NONE", "HOLD", "FOLLOW"
GOAL_TOLERANCE = 1e-6
"""m a status's goal may differ from the plan's before the goal counts as changed."""
PLAN_SEEDS = 4
"""LaCAM searches per plan (their seeds 1000 apart): the plan whose robots would all arrive first when driven by its
action dependencies (fleet_execution.execution_time), then of least makespan and cost, is kept."""
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
    expires: float = math.inf
    """s (statuses' clock): after this, without a newer word, the robot goes back to its own planning."""


@dataclass
class RobotStatus:
    stamp: float
    x: float
    y: float
    confident: bool
    """the navigator's verdict: sure enough to drive a path (NavigatorStatus.confident)."""
    goal: tuple[float, float] | None


@dataclass(frozen=True)
class PlanJob:
    """What one plan needs, taken on the coordinator's thread (begin_plan) and planned on any (compute_plan)."""

    generation: int
    costmap: Costmap
    spacing: float
    lattice: Lattice | None
    cut: tuple
    statuses: tuple
    goals: tuple
    restart: dict
    order: tuple
    """robot indices in priority order (the first planned first in a partial replan)."""
    follower_speed: float
    turn_rate: float
    replan: frozenset = frozenset()
    """robots to plan again around the others (a partial replan); empty: the whole fleet."""
    kept_plan: FleetPlan | None = None
    progress: tuple = ()
    """the kept robots' progress along kept_plan when the job was taken."""


@dataclass(frozen=True)
class PlanOutcome:
    job: PlanJob
    plan: FleetPlan | None
    lattice: Lattice | None
    cut: tuple
    error: str = ""
    events: tuple = ()
    partial: bool = False
    seconds: float = 0.0


def compute_plan(job: PlanJob) -> PlanOutcome:
    """The plan of `job` (no state of any coordinator touched: run it on a worker thread): a partial replan when the
    job names robots to plan again and one exists, else the whole fleet; the error when none could be made."""
    began = time.perf_counter()
    events = []
    graph = job.lattice
    cut = tuple(job.cut)
    try:
        if graph is None:
            graph = lattice(job.costmap, job.spacing)
        if job.replan and job.kept_plan is not None:
            plan = partial_plan(graph.without(cut), job)
            if plan is not None:
                return PlanOutcome(job, plan, graph, cut, partial=True, seconds=time.perf_counter() - began)
            events.append(
                f"no partial replan of {len(job.replan)} robots around the others: the whole fleet planned again"
            )
        try:
            plan = _plan_on(graph, graph.without(cut), job, job.restart)
        except (PlanningError, ValueError) as error:
            if not cut:
                raise
            # in a tree maze a vertex cut off may be the only way to a goal: the cuts were guesses at something
            # the map does not hold, and no plan at all is worse than meeting it again (the stuck rule stays)
            events.append(
                f"no fleet plan with {len(cut)} lattice edges cut off ({error}): they are "
                "restored, the fleet planned on the whole lattice"
            )
            cut = ()
            plan = _plan_on(graph, graph, job, job.restart)
    except (PlanningError, ValueError) as error:
        return PlanOutcome(job, None, graph, cut, str(error), tuple(events), seconds=time.perf_counter() - began)
    return PlanOutcome(job, plan, graph, cut, events=tuple(events), seconds=time.perf_counter() - began)


def _plan_on(whole: Lattice, graph: Lattice, job: PlanJob, restart: dict[int, int]) -> FleetPlan:
    """The fleet plan on `graph` from the robots' vertices (`restart`'s, else assigned to where they stand:
    amr_planning.fleet_lattice.assign) to the vertices nearest their goals; PlanningError or ValueError when
    none is found."""
    statuses = job.statuses
    moving = [robot for robot in range(len(statuses)) if robot not in restart]
    # a vertex whose every edge is cut is where a robot was stuck: no robot is planned from it
    blocked = [vertex for vertex in range(len(graph)) if not graph.neighbours[vertex] and whole.neighbours[vertex]]
    chosen = assign(
        graph,
        job.costmap,
        [(statuses[robot].x, statuses[robot].y) for robot in moving],
        taken=list(restart.values()) + blocked,
    )
    vertex_of = {**restart, **dict(zip(moving, chosen, strict=True))}
    starts = [vertex_of[robot] for robot in range(len(statuses))]
    goals = [graph.nearest(*goal) for goal in job.goals]  # two goals on one vertex: too close, refused
    plans = [improve(plan_lacam(graph, starts, goals, seed=1000 * k)) for k in range(PLAN_SEEDS)]
    return min(
        plans,
        key=lambda plan: (execution_time(plan, job.follower_speed, job.turn_rate), plan.makespan, plan.cost),
    )


def kept_paths(plan: FleetPlan, progress, kept) -> dict[int, list[int]]:
    """Each kept robot's remaining way along `plan` from its progress, timed step by step as its action dependencies
    on the other kept robots allow at the earliest (a robot enters a vertex only a step after the robot before it
    there has left: no two at one vertex, no swaps); dependencies on robots not kept are dropped."""
    needs = dependencies(plan)
    vertices = {robot: plan.vertices(robot) for robot in kept}
    at = {robot: progress[robot] for robot in kept}
    paths = {robot: [vertices[robot][at[robot]]] for robot in kept}
    for _ in range(sum(len(v) for v in vertices.values()) + 1):
        moving = [
            robot
            for robot in kept
            if at[robot] + 1 < len(vertices[robot])
            and all(at[other] >= action for other, action in needs[robot][at[robot] + 1] if other in at)
        ]
        if not moving:
            break
        for robot in moving:
            at[robot] += 1
        for robot in kept:
            paths[robot].append(vertices[robot][at[robot]])
    return paths


def partial_plan(graph: Lattice, job: PlanJob) -> FleetPlan | None:
    """The robots of job.replan planned again one at a time, in priority order, around the others' remaining ways
    (kept_paths) and those planned before them (A* in space and time); None when one has no such way, when a
    kept robot's way uses an edge no longer on `graph`, or the result would move robots round a cycle in one step."""
    robots = len(job.statuses)
    kept = [robot for robot in range(robots) if robot not in job.replan]
    paths: dict[int, list[int]] = kept_paths(job.kept_plan, job.progress, kept)
    for path in paths.values():
        if any(b != a and b not in graph.neighbours[a] for a, b in zip(path[:-1], path[1:], strict=True)):
            return None
    taken = [path[0] for path in paths.values()] + [
        vertex for vertex in range(len(graph)) if not graph.neighbours[vertex]
    ]
    for robot in [robot for robot in job.order if robot in job.replan]:
        status, goal = job.statuses[robot], job.goals[robot]
        start = job.restart.get(robot)
        if start is None:
            start = assign(graph, job.costmap, [(status.x, status.y)], taken=taken)[0]
        target = graph.nearest(*goal)
        fixed = [paths[other] for other in sorted(paths)] + [[start]]
        path = space_time_path(graph, start, target, graph.distances(target), around(fixed, len(fixed) - 1))
        if path is None:
            return None
        paths[robot] = path
        taken.append(start)
    ordered = [paths[robot] for robot in range(robots)]
    if rotates(ordered):
        return None
    return FleetPlan(graph, tuple(tuple(trim(tuple(path))) for path in ordered), 0)


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
        follower_speed: float = 0.2,
        turn_rate: float = 1.0,
        priorities: list[int] | None = None,
        route_lifetime: float = math.inf,
        partial: bool = True,
    ) -> None:
        if not names:
            raise ValueError("robots: the fleet has no robot")
        if len(set(names)) != len(names):
            raise ValueError(f"robots: a name is listed twice in {names}")
        if not (math.isfinite(spacing) and spacing > 0.0):
            raise ValueError(f"lattice_spacing: must be a positive number of metres, got {spacing!r}")
        for key, value in (("follower_speed", follower_speed), ("turn_rate", turn_rate)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{key}: must be a positive number, got {value!r}")
        if not (route_lifetime > 0.0):  # inf: routes never expire
            raise ValueError(f"route_lifetime: must be a positive number of seconds, got {route_lifetime!r}")
        self.names = list(names)
        if priorities is None:
            priorities = list(range(len(names)))
        if len(priorities) != len(names):
            raise ValueError(f"priorities: {len(priorities)} priorities for {len(names)} robots")
        self.priorities = [int(p) for p in priorities]
        """per robot: its priority (0 first): who is planned first in a partial replan."""
        self.order = tuple(sorted(range(len(names)), key=lambda robot: (self.priorities[robot], robot)))
        self.route_lifetime = float(route_lifetime)
        """s (statuses' clock) a route holds without a newer word (inf: for ever)."""
        self.partial = bool(partial)
        """a stuck or jumped robot is planned again around the others (else the whole fleet is)."""
        self.partial_plans = 0
        """plans made by planning only some robots again."""
        self._generation = 0
        """bumped when the plan is dropped or the map changes: a plan begun before is not adopted."""
        self.planning = False
        """a plan has been begun and not finished (begin_plan .. finish_plan)."""
        self._replan_robots: set[int] = set()
        """robots to plan again around the others (stuck or jumped), the plan in force kept meanwhile."""
        self.spacing = float(spacing)
        self.window = float(window)
        self.retry_period = float(retry_period)
        self.stuck_time = float(stuck_time)
        self.follower_speed, self.turn_rate = float(follower_speed), float(turn_rate)
        """m/s and rad/s the plans are timed at (fleet_execution.execution_time), to keep the one that ends first."""
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
        self._last: dict[str, Route] = {}
        """the FOLLOW route each robot was last told (renewed by renewals)."""
        self._job: PlanJob | None = None
        self._holding: set[str] = set()
        """robots told HOLD while a plan is made (not told their old routes meanwhile)."""
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
        self._generation += 1
        self._replan_robots = set()
        return self.drop("a new map") if self.schedule is not None else {}

    def observe(
        self, name: str, stamp: float, x: float, y: float, confident: bool, goal: tuple[float, float] | None
    ) -> dict[str, Route]:
        """One robot's status (s, m, its navigator's verdict, its goal or None): the routes that change, by robot
        name (ValueError for a robot not in the fleet or a pose that is not finite)."""
        if name not in self.names:
            raise ValueError(f"{name!r} is not a robot of the fleet ({', '.join(self.names)})")
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(stamp)):
            raise ValueError(f"{name}: status pose ({x}, {y}) at {stamp} is not finite")
        if goal is not None and not all(math.isfinite(v) for v in goal):
            goal = None
        before = self.statuses.get(name)
        self.statuses[name] = RobotStatus(
            float(stamp),
            float(x),
            float(y),
            bool(confident),
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
            return self._plan_again(robot)
        if self.schedule.report(robot, x, y):
            return self._routes()
        if self.schedule.allowed(robot) == self.schedule.progress[robot]:
            self._moving_since[robot] = stamp  # waiting for others, as planned
        elif stamp - self._moving_since[robot] > self.stuck_time:
            self._stuck(robot)
        return {}

    # -- planning ---------------------------------------------------------------------------------------

    def plan_due(self) -> bool:
        """No plan in force, the costmap known, and every robot's latest status confident with a goal, all within
        `window` s of one another (not before `retry_period` s after a failure)."""
        if self.planning:
            return False
        if self._replan_robots and self.schedule is not None:
            return True
        if self._replan and self.schedule is None and self._costmap is not None:
            return True
        if self.schedule is not None or self._costmap is None or len(self.statuses) < len(self.names):
            return False
        statuses = [self.statuses[name] for name in self.names]
        if not all(status.confident and status.goal is not None for status in statuses):
            return False
        stamps = [status.stamp for status in statuses]
        return max(stamps) - min(stamps) <= self.window and max(stamps) >= self._retry_at

    def hold(self) -> dict[str, Route]:
        """HOLD to every robot (while the plan is made)."""
        return self._tell(
            {
                name: self._stamped(Route(HOLD, plan=self.plans + 1, reason="the fleet is being planned"))
                for name in self.names
            }
        )

    def plan(self) -> dict[str, Route]:
        """Plan the fleet from where the robots said they stand to their goals, here and now (begin_plan,
        compute_plan, finish_plan): every robot's route (FOLLOW), or NONE to every one with the reason when no
        plan could be made."""
        self.begin_plan()
        return self.finish_plan(compute_plan(self._job))

    def begin_plan(self) -> tuple[PlanJob, dict[str, Route]]:
        """The job of the plan due (for compute_plan, on any thread) and what to tell the robots meanwhile: HOLD to
        those planned again (every robot for a whole plan; in a partial replan only those, the others driving on)."""
        statuses = tuple(self.statuses[name] for name in self.names)
        partial = bool(self._replan_robots) and self.schedule is not None and self.partial
        replan = frozenset(self._conflicting(self._replan_robots)) if partial else frozenset()
        if not partial:
            self.schedule = None
        goals = tuple(self._goals) if partial else tuple(status.goal for status in statuses)
        restart, self._restart = self._restart, {}
        self._job = PlanJob(
            self._generation,
            self._costmap,
            self.spacing,
            self._lattice,
            tuple(self.cut),
            statuses,
            goals,
            restart,
            self.order,
            self.follower_speed,
            self.turn_rate,
            replan,
            self.schedule.plan if partial else None,
            tuple(self.schedule.progress) if partial else (),
        )
        self._replan, self._replan_robots, self.planning = False, set(), True
        holding = [self.names[robot] for robot in sorted(replan)] if partial else list(self.names)
        self._holding = set(holding)
        routes = {
            name: self._stamped(Route(HOLD, plan=self.plans + 1, reason="the fleet is being planned"))
            for name in holding
        }
        for name in holding:
            self._told[name] = (HOLD, self.plans + 1)
            self._last.pop(name, None)  # a HOLD is not renewed
        return self._job, routes

    def finish_plan(self, outcome: PlanOutcome) -> dict[str, Route]:
        """Adopt the plan of a job begun by begin_plan: the routes that change (every robot's FOLLOW, or NONE to every
        one with the reason when none was made); {} when the plan was dropped or the map changed since."""
        self.planning, self._holding = False, set()
        job = outcome.job
        if job.generation != self._generation or (job.kept_plan is not None and self.schedule is None):
            return {}
        for name, goal in zip(self.names, job.goals, strict=True):  # a goal changed while it was planned
            now = self.statuses[name].goal
            if now is None or math.hypot(now[0] - goal[0], now[1] - goal[1]) > GOAL_TOLERANCE:
                self.schedule = None
                return {}
        self.planning_time = outcome.seconds
        self.events.extend(outcome.events)
        self._lattice, self.cut = outcome.lattice, list(outcome.cut)
        if outcome.plan is None:
            self.schedule = None
            self.failures.append(outcome.error)
            self._retry_at = max(status.stamp for status in job.statuses) + self.retry_period
            return self._tell(
                {
                    name: self._stamped(
                        Route(
                            NONE,
                            reason=f"no fleet plan: {outcome.error}; by the traffic rules, planning "
                            f"again in {self.retry_period:g} s",
                        )
                    )
                    for name in self.names
                }
            )
        before = self.schedule
        self.plans += 1
        self._goals = list(job.goals)
        self.schedule = Schedule(outcome.plan, self._goals)
        if outcome.partial:
            self.partial_plans += 1
            for robot in range(len(self.names)):  # a kept robot drove on while the plan was made
                if robot not in job.replan and before is not None:
                    moved = before.progress[robot] - job.progress[robot]
                    self.schedule.progress[robot] = min(max(0, moved), len(self.schedule.waypoints[robot]) - 1)
        latest = max(status.stamp for status in self.statuses.values())
        self._moving_since = [latest] * len(self.names)
        return self._routes()

    def route(self, name: str) -> Route:
        """What `name` is told now by the plan in force (FOLLOW), NONE without one."""
        if self.schedule is None:
            return Route(NONE, reason="no fleet plan yet")
        schedule, robot = self.schedule, self.names.index(name)
        status = self.statuses[name]
        waypoints = schedule.route(robot, status.x, status.y)[1:]
        last = len(schedule.waypoints[robot]) - 1
        final = schedule.allowed(robot) == last and bool(np.allclose(waypoints[-1], schedule.waypoints[robot][last]))
        return self._stamped(
            Route(
                FOLLOW,
                waypoints,
                final,
                self.plans,
                schedule.progress[robot],
                last,
                f"{len(self.names)} robots, planned in {self.planning_time:.2f} s",
            )
        )

    # -- helpers ----------------------------------------------------------------------------------------

    def _span(self, robot: int) -> tuple:
        return FOLLOW, self.plans, self.schedule.progress[robot], self.schedule.allowed(robot)

    def _routes(self) -> dict[str, Route]:
        """The FOLLOW routes whose span changed since the robot was last told (its stuck clock restarted)."""
        changed = {}
        for robot, name in enumerate(self.names):
            if name in self._holding:
                continue
            span = self._span(robot)
            if self._told.get(name) != span:
                self._told[name] = span
                self._moving_since[robot] = self.statuses[name].stamp
                changed[name] = self._last[name] = self.route(name)
        return changed

    def renewals(self) -> dict[str, Route]:
        """Each FOLLOW route past half its lifetime, told again with a new expiry (a HOLD is never renewed)."""
        if not math.isfinite(self.route_lifetime) or not self.statuses:
            return {}
        now = self._now()
        renewed = {}
        for name, route in self._last.items():
            if route.state == FOLLOW and route.expires - now < 0.5 * self.route_lifetime:
                renewed[name] = self._last[name] = replace(route, expires=now + self.route_lifetime)
        return renewed

    def _now(self) -> float:
        return max((status.stamp for status in self.statuses.values()), default=0.0)

    def _stamped(self, route: Route) -> Route:
        return replace(route, expires=self._now() + self.route_lifetime)

    def _plan_again(self, robot: int) -> dict[str, Route]:
        """Plan `robot` again (stuck or jumped): around the others, who keep their routes (partial), or the whole
        fleet when partial replans are off."""
        if self.partial:
            self._replan_robots.add(robot)
        else:
            self.schedule, self._replan = None, True
        return {}

    def _conflicting(self, robots: set[int]) -> set[int]:
        """`robots` and every robot whose remaining way passes a vertex cut off."""
        schedule = self.schedule
        blocked = {vertex for vertex, _ in self.cut}  # _stuck cuts every edge of the vertex, from it
        conflicting = set(robots)
        for robot in range(len(self.names)):
            remaining = schedule.plan.vertices(robot)[schedule.progress[robot] + 1 :]
            if blocked.intersection(remaining):
                conflicting.add(robot)
        return conflicting

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
        self._moving_since[robot] = status.stamp
        self._plan_again(robot)

    def take_events(self) -> list[str]:
        events, self.events = self.events, []
        return events

    def _tell(self, routes: dict[str, Route]) -> dict[str, Route]:
        for name, route in routes.items():
            self._told[name] = (route.state, route.plan)
        return routes

    def drop(self, why: str) -> dict[str, Route]:
        """Drop the plan in force (if any): NONE to every robot, with `why`."""
        self.schedule, self._replan_robots, self._last = None, set(), {}
        self._generation += 1
        return self._tell(
            {
                name: Route(
                    NONE,
                    reason=f"the fleet plan was dropped: {why}; by the traffic rules "
                    "until every robot is confident again",
                )
                for name in self.names
            }
        )
