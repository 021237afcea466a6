"""One robot's traffic rules among others (`Traffic`), without ROS. The rules, what each does and why, are explained
in docs/amr_navigation.md ("Traffic: several robots") and the cases each was added for in
docs/decisions/2026-11-26-traffic-rules.md; the geometry they use is amr_navigation.traffic_geometry, the board
amr_navigation.traffic_board.

The navigator of one robot asks `Traffic.advise` on every observation it drives with the path follower
(amr_navigation.loop.NavigationLoop with a `Traffic`, amr_navigation.navigator_core through ROS) and posts the
others with `post_idle` / `wants_to_move`; the rules decide, the path follower follows: a speed cap (0: stop), a
plan around unmapped returns, a detour to a place aside, a hold. The rules, by the numbers the code's comments use:

1. Stop for what is in the way: unmapped scan returns (farther than `map_tolerance` from the map) on the path
   ahead cap the speed (`obstacle_speed`); a stopped robot moves on past `stop_distance` + RESUME_MARGIN.
2. Wait `wait_time`, then plan around them (marks cleared once the scan sees through them).
   2b. Back off from returns no post explains, after `yield_timeout` with every plan around them failed.
3. Right of way: a robot gives way to one it blocks that blocks it too and has the right of way (lower
   priority number) or cannot give way; a passive robot (at its goal, waiting aside) makes way for anyone it
   blocks. It waits at the nearest place within `yield_search` m, 2 `robot_radius` + `yield_clearance` from
   their paths and centres, until they need it no more or stood still `yield_timeout`; with none it posts
   `cannot_yield`.
4. Way out: a passive robot boxed in looks past the robots it blocks, which make way for it first.
5. Search farther: of two robots that both cannot give way, the lower-priority one searches the whole map
   (past robots parked at their goals), then the other after `wait_time`.
6. Make room: searching farther, a robot finally looks past robots waiting behind it, which make way first.
7. Knot: of three or more robots blocked in a cycle, the lowest priority gives way.

Invariants: what a robot knows of the others is exactly their posts (`TrafficPost`). Of two robots blocked by
each other exactly one gives way (the rule is the same with the roles swapped), so two robots face to face in a
one-wide corridor with a side pocket or a junction on either side of the meeting point never deadlock. Not
resolved: neither side has a place anywhere (each a bare corridor ending at the other's goal: no swap is
possible), and a robot on the way that is not parked (exploring, or itself giving way) counts as a wall.
tests/navigation/test_traffic.py holds each rule to a world made for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np

from amr_navigation.traffic_board import TrafficBoard, TrafficPost
from amr_navigation.traffic_geometry import (
    farthest_place,
    free_travel,
    min_distance,
    obstacle_speed,
    path_ahead,
    place_aside,
    scan_points,
    unmapped,
)
from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError
from amr_planning.planner import Planner
from amr_util.parameter_spec import Config, ConfigError, parameter
from amr_util.robot_description import default_robot
from amr_util.scan import ScanData

PROGRESS = 0.05
"""m a robot must move for a robot waiting on it to count it as making progress (which restarts its timeout)."""
RESUME_MARGIN = 0.05
"""m beyond stop_distance the free travel must reach before a stopped robot moves on (without it, range noise
and the estimate's jitter around stop_distance made a robot stop and creep a few times a second: each counted
as a stop, and each restarted the wait before planning around)."""
NODE_NAME = "traffic"
"""the section of config/traffic.yaml (the traffic rules' parameters; the navigator would declare them)."""


@dataclass(frozen=True)
class TrafficConfig(Config):
    robot_radius: float = parameter(default_robot().radius, minimum=0.01, maximum=2.0, live=True)
    """m, every robot's disc (default: the robot description's footprint)."""
    lidar_x: float = parameter(default_robot().lidar_x, minimum=-1.0, maximum=1.0, live=True)
    """m, LiDAR position ahead of the rotation centre (default: the robot description's mount)."""
    map_tolerance: float = parameter(0.08, minimum=0.0, maximum=1.0, live=True)
    """m: a scan return farther than this from every obstacle of the map is unmapped (estimate error and
    range noise stay within it)."""
    path_clearance: float = parameter(0.03, minimum=0.0, maximum=1.0, live=True)
    """m beyond robot_radius: a return this close to the path ahead is in the way."""
    min_returns: int = parameter(3, minimum=1, maximum=100, live=True)
    """unmapped returns that must be in the way before the robot slows or stops (single noisy beams do not)."""
    stop_distance: float = parameter(0.12, minimum=0.0, maximum=5.0, live=True)
    """m of free travel along the path at or below which the robot stops."""
    slow_distance: float = parameter(0.45, minimum=0.01, maximum=10.0, live=True)
    """m of free travel from which on the speed is not capped (linear from 0 at stop_distance)."""
    wait_time: float = parameter(2.0, minimum=0.0, maximum=600.0, live=True)
    """s stopped by an unmapped obstacle before planning around it (and between failed attempts)."""
    mark_radius: float = parameter(0.04, minimum=0.0, maximum=1.0, live=True)
    """m, disc marked around each unmapped return (and a point one robot radius behind it) for a replan."""
    mark_range: float = parameter(1.5, minimum=0.1, maximum=20.0, live=True)
    """m, unmapped returns within this of the robot are marked for a replan."""
    clear_distance: float = parameter(0.15, minimum=0.01, maximum=5.0, live=True)
    """m a beam must reach beyond a mark for the mark to count as gone."""
    conflict_distance: float = parameter(0.9, minimum=0.1, maximum=10.0, live=True)
    """m of path ahead posted on the board and checked for other robots (who blocks whom)."""
    yield_clearance: float = parameter(0.15, minimum=0.0, maximum=2.0, live=True)
    """m beyond 2 robot_radius: a place to wait aside is at least this far from the others' paths (more than
    path_clearance, plus the path follower's goal tolerance)."""
    yield_search: float = parameter(4.0, minimum=0.1, maximum=50.0, live=True)
    """m of steps at most from the robot to a place to wait aside."""
    yield_timeout: float = parameter(20.0, minimum=0.1, maximum=3600.0, live=True)
    """s waiting aside while the robots it gives way to stand still (each move of theirs restarts it), or held
    for a robot that gives way, before going on regardless."""

    def validate(self) -> None:
        if self.slow_distance <= self.stop_distance:
            raise ConfigError(f"slow_distance ({self.slow_distance}) must exceed stop_distance ({self.stop_distance})")
        if self.yield_clearance <= self.path_clearance:
            raise ConfigError(
                f"yield_clearance ({self.yield_clearance}) must exceed path_clearance "
                f"({self.path_clearance}): a robot waiting aside must not block the path it cleared"
            )


# -- one robot's rules ------------------------------------------------------------------------------


class Phase(StrEnum):
    GO = "GO"
    """following its path (perhaps slowed or stopped for an obstacle)."""
    YIELD = "YIELD"
    """driving to a place aside, out of the way of a robot with the right of way."""
    ASIDE = "ASIDE"
    """waiting at that place until the other has passed."""


@dataclass(frozen=True)
class Advice:
    """What the traffic rules say for one observation."""

    speed_limit: float | None = None
    """m/s cap for the path follower (0: stop); None: no cap."""
    replan_around: np.ndarray | None = None
    """(K, 2) unmapped returns to mark before planning to the goal again (the wait is over)."""
    replan: bool = False
    """plan to the goal again on the map (marks gone, or a detour is over)."""
    detour: np.ndarray | None = None
    """(N, 2) a path to a place aside, to follow instead of the path to the goal."""
    hold: bool = False
    """stand still (waiting aside)."""
    events: tuple[str, ...] = ()


@dataclass
class TrafficCounters:
    stops: int = 0
    """times the robot was stopped by an unmapped obstacle."""
    replans_around: int = 0
    yields: int = 0
    """times it gave way (went aside)."""
    cannot_yield: int = 0


class Traffic:
    """One robot's traffic rules (see the module docstring); the navigator loop calls `advise` on every
    observation it drives with the path follower and `post_idle` on the others."""

    def __init__(self, name: str, priority: int, board: TrafficBoard, config: TrafficConfig | None = None) -> None:
        self.name = name
        self.priority = int(priority)
        self.board = board
        self.config = config or TrafficConfig()
        self.phase = Phase.GO
        self.counters = TrafficCounters()
        self.marks = np.zeros((0, 2))
        """unmapped returns the current path was planned around."""
        self._stopped_since: float | None = None
        self._last_attempt: float | None = None
        self._waiting_for_yield_since: float | None = None
        self._yield_to: tuple[str, ...] = ()
        self._spot: tuple[float, float] | None = None
        self._aside_since: float | None = None
        self._cannot_yield = False
        self._route = np.zeros((0, 2))
        self._remaining = np.zeros((0, 2))
        self._awaited: dict[str, tuple[float, float]] = {}
        self._retry_at = -math.inf
        self._through: tuple[str, ...] = ()
        """the robots a boxed-in robot's way aside passes (they make way for it first)."""
        self._detour = np.zeros((0, 2))
        self._said_cannot: dict[str, float] = {}
        self._failing_since: float | None = None
        """the stamp of the first of the searches for a place aside that have failed since (rule 5)."""
        """the last stamp at which each other robot was seen posting cannot_yield (rule 5)."""
        """the path to the place aside."""
        """no place to wait was found: the next search is not before this stamp."""
        """while giving way: the detour reversed and the stretch of path left (what the others must clear)."""

    # -- per observation -------------------------------------------------------------------------

    def post_idle(self, pose: tuple[float, float, float] | None, passive: bool) -> None:
        """Post for an observation nobody drives with a path (exploring: pose None; at the goal: passive)."""
        self.board.post(TrafficPost(self.name, self.priority, pose, None, "", (), passive, False))

    def wants_to_move(self, pose: tuple[float, float, float], costmap: Costmap, stamp: float) -> Advice | None:
        """At the goal (passive): a detour if some robot is blocked by this one, else None."""
        blocked = [post for post in self.board.others(self.name) if post.blocked_by == self.name]
        if not blocked or stamp < self._retry_at:
            self.post_idle(pose, True)
            return None
        return self._go_aside(pose, costmap, blocked, stamp, passive=True)

    def advise(
        self,
        pose: tuple[float, float, float],
        scan: ScanData,
        path: np.ndarray,
        costmap: Costmap,
        speed: float,
        stamp: float,
    ) -> Advice:
        """The advice for one observation driven with the path follower along `path` (the followed one)."""
        config = self.config
        x, y, theta = pose
        remaining = path_ahead(path, x, y, math.inf, spacing=0.05)
        stretch = path_ahead(path, x, y, config.conflict_distance)
        self._remaining = remaining
        others = [post for post in self.board.others(self.name) if post.pose is not None]
        blocker = self._blocker(pose, stretch, others)
        events: list[str] = []
        for post in others:
            if post.cannot_yield:
                self._said_cannot[post.name] = stamp
        if blocker is None:
            self._failing_since = None

        if self.phase is not Phase.GO:
            advice = self._yielding(pose, stretch, costmap, others, stamp)
            if advice is not None:
                return advice
            events.append("done giving way: planning to the goal again")
            self.phase, self._spot, self._yield_to, self._through = Phase.GO, None, (), ()
            self._remaining = self._route  # until the new plan: the way back and the stretch it left
            self._post(pose, None)
            return Advice(replan=True, events=tuple(events))

        # right of way: yield to a robot blocked by this one when the rule says so
        yield_to = [post for post in others if post.blocked_by == self.name and self._must_yield(post, blocker)]
        knot = []
        if not yield_to and blocker is not None:  # rule 7: a knot of three or more, the last of it gives way
            knot = self._knot(blocker)
            yield_to = knot[-1:]
        if stamp < self._retry_at:
            yield_to = []  # no place to wait was found: look again after wait_time, not every observation
        if yield_to:
            # rule 5: the lower-priority robot of a pair that both cannot yield searches the whole map
            # (the other's flag is read as seen within wait_time: both look again every wait_time, and the other
            # clears its flag for the observation on which it looks again)
            # the one with the right of way searches farther too once its own search has failed for wait_time
            # (the other has had its turn at the farther search)
            failing = self._failing_since is not None and stamp - self._failing_since >= config.wait_time
            far = any(
                (failing or not self._outranks(post))
                and stamp - self._said_cannot.get(post.name, -math.inf) <= config.wait_time
                for post in yield_to
            )
            far = far or bool(knot and failing)  # rule 7: no place nearby for wait_time, the knot's last looks farther
            advice = self._go_aside(
                pose, costmap, yield_to, stamp, passive=False, stretch=stretch, blocker=blocker, far=far
            )
            if advice is not None:
                if knot:
                    advice = replace(
                        advice,
                        events=advice.events
                        + (
                            f"the last of a knot of {len(knot) + 1} "
                            f"({', '.join([self.name] + [p.name for p in knot])}, each blocked by the next)",
                        ),
                    )
                return advice
        elif stamp >= self._retry_at:
            self._cannot_yield = False

        # the robot ahead is making way for this one: hold until it is off this stretch of path
        if blocker is not None and self.name in blocker.yielding_to:
            if self._waiting_for_yield_since is None:
                self._waiting_for_yield_since = stamp
            if stamp - self._waiting_for_yield_since < config.yield_timeout:
                self._post(pose, blocker)
                return Advice(speed_limit=0.0)
        else:
            self._waiting_for_yield_since = None

        # stop for what the scan shows in the way
        world, local = scan_points(scan, pose, config.lidar_x)
        loose = unmapped(costmap, world, config.map_tolerance)
        front = loose & (local[:, 0] > 0.0)
        travel = free_travel(stretch, world[front], config.robot_radius + config.path_clearance, config.min_returns)
        limit = obstacle_speed(travel, config.stop_distance, config.slow_distance, speed)
        if self._stopped_since is not None and not travel > config.stop_distance + RESUME_MARGIN:
            limit = 0.0  # stopped: moves on only once the way is clear by a margin (hysteresis)
        self._post(pose, blocker)
        self._clear_marks(world, pose, events)
        if len(self.marks) == 0 and self._marked_path:
            self._marked_path = False
            events.append("the obstacles planned around are gone: planning on the map again")
            return Advice(replan=True, events=tuple(events))
        if limit > 0.0:
            self._stopped_since = None
            return Advice(speed_limit=limit if limit < speed else None, events=tuple(events))
        if self._stopped_since is None:
            self._stopped_since = self._last_attempt = stamp
            self.counters.stops += 1
            events.append(
                f"stopped: an obstacle not on the map {travel:.2f} m ahead"
                + (f" ({blocker.name})" if blocker is not None else "")
            )
        near = np.hypot(world[:, 0] - x, world[:, 1] - y) <= config.mark_range
        if blocker is None and stamp - self._stopped_since >= config.yield_timeout and stamp >= self._retry_at:
            # rule 2b: stopped for yield_timeout by something no robot on the board explains (and no way around it)
            advice = self._back_off(pose, costmap, world[loose & near], stretch, stamp)
            if advice is not None:
                return replace(advice, events=tuple(events) + advice.events)
        if stamp - self._last_attempt >= config.wait_time:
            self._last_attempt = stamp
            marks = _extend(world[loose & near], (x, y), config.robot_radius)
            events.append(f"waited {config.wait_time:g} s: planning around {len(marks)} marked points")
            return Advice(speed_limit=0.0, replan_around=marks, events=tuple(events))
        return Advice(speed_limit=0.0, events=tuple(events))

    def replanned_around(self, marks: np.ndarray, success: bool) -> None:
        """The loop's report on a replan_around advice: the marks stay while the path planned around them is
        followed (a failed plan keeps nothing)."""
        if success:
            self.marks = np.asarray(marks, dtype=float).reshape(-1, 2)
            self._marked_path = True
            self.counters.replans_around += 1
            self._stopped_since = None

    _marked_path = False

    # -- helpers ---------------------------------------------------------------------------------

    def _post(self, pose, blocker, passive: bool = False) -> None:
        self.board.post(
            TrafficPost(
                self.name,
                self.priority,
                tuple(pose),
                self._remaining,
                blocker.name if blocker is not None else "",
                self._yield_to,
                passive,
                self._cannot_yield,
            )
        )

    def _blocker(self, pose, stretch: np.ndarray, others: list[TrafficPost]) -> TrafficPost | None:
        """The other robot nearest along the stretch whose centre lies on it (within 2 r + path_clearance), in
        front of this robot."""
        config = self.config
        x, y, theta = pose
        c, s = math.cos(theta), math.sin(theta)
        best, best_arc = None, math.inf
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(stretch, axis=0).T))])
        for post in others:
            ox, oy = post.pose[0], post.pose[1]
            if c * (ox - x) + s * (oy - y) <= 0.0:
                continue  # behind
            gaps = np.hypot(stretch[:, 0] - ox, stretch[:, 1] - oy)
            on = np.flatnonzero(gaps <= 2.0 * config.robot_radius + config.path_clearance)
            if len(on) and arc[on[0]] < best_arc:
                best, best_arc = post, arc[on[0]]
        return best

    def _knot(self, blocker: TrafficPost) -> list[TrafficPost]:
        """Rule 7: the other robots of a cycle of three or more, each blocked by the next (this one by `blocker`,
        the last of them by this one; none passive or giving way) when this one is the last of the cycle (the
        lowest priority); else []. The last of the list is the robot this one blocks."""
        posts = {post.name: post for post in self.board.others(self.name) if post.pose is not None}
        chain = [blocker]
        while chain[-1].blocked_by != self.name:
            following = posts.get(chain[-1].blocked_by)
            if following is None or any(post.name == following.name for post in chain):
                return []  # no cycle through this robot
            chain.append(following)
        if len(chain) < 2 or any(post.passive or post.yielding_to for post in chain):
            return []  # a pair (rule 3), or someone in it already makes way
        return chain if not any(self._outranks(post) for post in chain) else []

    def _outranks(self, post: TrafficPost) -> bool:
        return (self.priority, self.name) < (post.priority, post.name)

    def _must_yield(self, post: TrafficPost, blocker: TrafficPost | None) -> bool:
        """`post` is blocked by this robot: does this one give way?"""
        if post.passive:
            return False
        mutual = blocker is not None and blocker.name == post.name
        if not mutual:
            return False
        if self._cannot_yield:
            return False
        return not self._outranks(post) or post.cannot_yield

    def _go_aside(
        self,
        pose,
        costmap: Costmap,
        yield_to: list[TrafficPost],
        stamp: float,
        passive: bool,
        stretch: np.ndarray | None = None,
        blocker: TrafficPost | None = None,
        far: bool = False,
    ) -> Advice | None:
        config = self.config
        search = config.yield_search
        if far:  # rule 5: no bound but the map (every cell reachable without passing another robot)
            search = max(search, _whole_map(costmap))
        distance = 2.0 * config.robot_radius + config.yield_clearance
        avoid = [np.asarray(post.path).reshape(-1, 2) for post in yield_to if post.path is not None]
        avoid += [np.array([post.pose[:2]]) for post in yield_to]
        names = tuple(post.name for post in yield_to)
        others = {post.name: post.pose[:2] for post in self.board.others(self.name) if post.pose is not None}
        if far:  # rule 5: robots parked at their goals make way (rule 3) for one driving past them: not walls here
            parked = [
                post
                for post in self.board.others(self.name)
                if post.pose is not None
                and post.passive
                and post.path is None
                and not post.yielding_to
                and post.name not in names
            ]
            for post in parked:
                del others[post.name]
            avoid += [np.array([post.pose[:2]]) for post in parked]  # the place is not where one is parked
        # a place the robot reaches without passing anyone; a passive robot boxed in (its only way out is
        # where the robots it blocks stand) may pass them: they make way for it (the way-out rule)
        # rule 6 (make room): last, when searching farther (rule 5), a place past any other robot (one behind
        # this one in a corridor, itself waiting for the robot ahead); driving there this robot holds before it
        # and posts it as its blocker, unable to give way, and it makes way first (rule 3), as the robots a
        # boxed-in one passes do (rule 4)
        bystanders = tuple(name for name in others if name not in names)
        attempts = [(), names] if passive else [()]
        if bystanders and far:  # only once neither robot could give way (rule 5): else the other gives way
            attempts.append(bystanders)
        spot = detour = None
        for passing in attempts:
            discs = [xy for name, xy in others.items() if name not in passing]
            marked = costmap.with_obstacles(np.array(discs), config.robot_radius) if discs else costmap
            # a place is not where a robot passed stands
            stand = [np.array([others[name]]) for name in passing if name in others and name not in names]
            spot = place_aside(marked, pose[:2], np.concatenate(avoid + stand), distance, search)
            if spot is None:
                continue
            try:
                detour = Planner(marked.grid, costmap=marked).plan(pose[:2], spot)
            except PlanningError:
                continue
            self._through = tuple(sorted(set(self._through) | set(passing)))
            way = (
                f" past {', '.join(passing)} (they make way first)"
                if passing and passing == bystanders
                else f" past {', '.join(passing)} (boxed in: they make way first)"
                if passing
                else ""
            )
            if far:
                way += f" (neither could give way within {config.yield_search:g} m: searched farther)"
            break
        if detour is None:
            if self._failing_since is None:
                self._failing_since = stamp
            if not self._cannot_yield:
                self.counters.cannot_yield += 1
            self._cannot_yield = True
            self._retry_at = stamp + config.wait_time
            if passive:
                self.post_idle(pose, True)
            else:
                self._post(pose, blocker)
            return None
        self._cannot_yield = False
        self._failing_since = None
        return self._set_off(
            pose,
            spot,
            detour,
            names,
            stretch,
            stamp,
            f"giving way to {', '.join(names)}: going aside to ({spot[0]:.2f}, {spot[1]:.2f}){way}",
        )

    def _set_off(
        self,
        pose,
        spot: tuple[float, float],
        detour: np.ndarray,
        names: tuple[str, ...],
        stretch: np.ndarray | None,
        stamp: float,
        event: str,
    ) -> Advice:
        """Drive to `spot` along `detour` and wait there (phase YIELD, then ASIDE), giving way to `names` (none: rule
        2b); the route back is the detour reversed and the stretch of path it leaves (or, already aside, the route
        it had)."""
        self.counters.yields += 1
        if self.phase is Phase.GO:  # the way back to where it left its path, and the stretch it left
            behind = np.asarray(stretch if stretch is not None else [pose[:2]], dtype=float).reshape(-1, 2)
            self._route = np.concatenate([np.asarray(detour)[::-1], behind])
        else:
            self._route = np.concatenate([np.asarray(detour)[::-1], self._route])
        self.phase, self._spot, self._yield_to, self._aside_since = Phase.YIELD, spot, names, stamp
        self._awaited = {}
        self._stopped_since = None
        self._detour = np.asarray(detour, dtype=float).reshape(-1, 2)
        self.board.post(TrafficPost(self.name, self.priority, tuple(pose), self._detour, "", names, True, False))
        return Advice(detour=detour, events=(event,))

    def _back_off(self, pose, costmap: Costmap, points: np.ndarray, stretch: np.ndarray, stamp: float) -> Advice | None:
        """Rule 2b: back off to the nearest place `mark_range` from the unmapped returns in the way, and wait there
        for yield_timeout before planning to the goal again. What stands there may be a robot whose filter is not
        sure where it is: it posts no position, so no rule of the others sees it, and in a dead end the robot
        waiting at its mouth blocks both its way out and the view its filter needs."""
        config = self.config
        discs = [post.pose[:2] for post in self.board.others(self.name) if post.pose is not None]
        # a return is a point on a surface, marked as the cell it lies in (the costmap keeps the robot's centre a
        # radius from it, as from a wall); a posted robot is its disc. Returns marked as discs would put the
        # robot's own cell inside them when what it backs off from stands closer than two radii: no way out.
        marked = costmap.with_obstacles(points, 0.0).with_obstacles(np.array(discs).reshape(-1, 2), config.robot_radius)
        spot = place_aside(marked, pose[:2], points, config.mark_range, _whole_map(costmap))
        if spot is None and len(points):  # a dead end shorter than mark_range: back off as far as it goes
            farthest = farthest_place(marked, pose[:2], points)
            standing = float(np.hypot(*(np.asarray(points, dtype=float).reshape(-1, 2) - pose[:2]).T).min())
            if farthest is not None and farthest[1] >= standing + 2.0 * config.robot_radius:
                spot = farthest[0]
        detour = None
        if spot is not None:
            try:
                detour = Planner(marked.grid, costmap=marked).plan(pose[:2], spot)
            except PlanningError:
                detour = None
        if detour is None:
            self._retry_at = stamp + config.wait_time  # look again after wait_time, as a failed search aside does
            return None
        return self._set_off(
            pose,
            spot,
            detour,
            (),
            stretch,
            stamp,
            (
                f"stopped {config.yield_timeout:g} s by something not on the map and not on the board (a robot not "
                f"sure where it is?): backing off to ({spot[0]:.2f}, {spot[1]:.2f}) to let it move"
            ),
        )

    def _yielding(self, pose, stretch, costmap, others, stamp) -> Advice | None:
        """The advice while going or waiting aside; None once the wait is over: every robot it gives way to
        is clear of its route (the way it came aside and the stretch of path it left), or is passive, or
        yield_timeout has passed."""
        config = self.config
        reach = 2.0 * config.robot_radius + config.path_clearance
        driving = self.phase is Phase.YIELD
        # on the way aside the post carries the rest of the detour (robots it gives way to wait until it is off
        # their way); once there, no path
        way = path_ahead(self._detour, pose[0], pose[1], math.inf, spacing=0.05) if driving else None
        self.board.post(TrafficPost(self.name, self.priority, tuple(pose), way, "", self._yield_to, True, False))
        for post in others:  # the wait times out only while the robots it gives way to stand still
            if post.name in self._yield_to:
                last = self._awaited.get(post.name)
                if last is None or math.hypot(post.pose[0] - last[0], post.pose[1] - last[1]) > PROGRESS:
                    self._awaited[post.name] = (post.pose[0], post.pose[1])
                    self._aside_since = stamp
        if stamp - self._aside_since >= config.yield_timeout:
            return None
        # someone newly blocked by this robot (or, waiting aside, one it gives way to that now finds it in its
        # way): go aside for them too
        fresh = [
            post
            for post in others
            if post.blocked_by == self.name
            and (post.name not in self._yield_to or (self.phase is Phase.ASIDE and not post.passive))
            # rule 6: a robot this one drives past makes way for it, not the other way round
            and not (driving and post.name in self._through and post.name not in self._yield_to)
        ]
        if fresh and stamp >= self._retry_at:
            renewed = {post.name for post in fresh}
            keep = [post for post in others if post.name in self._yield_to and post.name not in renewed]
            advice = self._go_aside(pose, costmap, keep + fresh, stamp, passive=True)
            if advice is not None:
                return advice
        if driving:
            # a robot standing on the way aside: hold, and tell it this one cannot give way (it makes way)
            blocker = self._blocker(pose, path_ahead(self._detour, pose[0], pose[1], config.conflict_distance), others)
            if blocker is not None:
                self.board.post(TrafficPost(self.name, self.priority, tuple(pose), way, blocker.name, (), False, True))
                return Advice(hold=True)
            self.board.post(TrafficPost(self.name, self.priority, tuple(pose), way, "", self._yield_to, True, False))
            return Advice()  # follow the detour (the loop reports its end with `arrived`)
        if not self._yield_to:
            return Advice(hold=True)  # backed off from something not on the board (rule 2b): until yield_timeout
        posts = {post.name: post for post in self.board.others(self.name)}
        for name in self._yield_to:
            post = posts.get(name)
            if post is not None and name in self._through and self.name in post.yielding_to:
                return Advice(hold=True)  # boxed in, it came out past this robot: that one goes first
            if post is None or (post.passive and post.path is None):
                continue
            if post.pose is None:
                return Advice(hold=True)  # lost: wait (at most yield_timeout)
            if min_distance(self._route, post.pose[0], post.pose[1]) < reach:
                return Advice(hold=True)
            if post.path is not None and len(post.path) and _near(post.path, self._route, reach):
                return Advice(hold=True)
        return None

    def arrived(self, stamp: float) -> None:
        """The detour's end was reached: wait there."""
        if self.phase is Phase.YIELD:
            self.phase = Phase.ASIDE

    def _clear_marks(self, world: np.ndarray, pose, events: list[str]) -> None:
        """Drop the marks the scan now sees through (a return beyond them along their bearing)."""
        if len(self.marks) == 0:
            return
        x, y = pose[0], pose[1]
        bearings = np.arctan2(world[:, 1] - y, world[:, 0] - x)
        ranges = np.hypot(world[:, 0] - x, world[:, 1] - y)
        keep = []
        for mark in self.marks:
            bearing = math.atan2(mark[1] - y, mark[0] - x)
            distance = math.hypot(mark[0] - x, mark[1] - y)
            near = np.abs(np.angle(np.exp(1j * (bearings - bearing)))) <= 0.03
            seen_through = near.any() and ranges[near].min() >= distance + self.config.clear_distance
            if not seen_through:
                keep.append(mark)
        self.marks = np.array(keep).reshape(-1, 2)


def _whole_map(costmap: Costmap) -> float:
    """m of steps that reach every cell of the map (a search bound of no bound but the map)."""
    return (costmap.grid.width + costmap.grid.height) * costmap.grid.resolution


def _near(a: np.ndarray, b: np.ndarray, reach: float) -> bool:
    """Some point of a (N, 2) lies within reach of some point of b (M, 2)."""
    a, b = np.asarray(a, dtype=float).reshape(-1, 2), np.asarray(b, dtype=float).reshape(-1, 2)
    if len(a) == 0 or len(b) == 0:
        return False
    return bool((np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1]) < reach).any())


def _extend(points: np.ndarray, origin: tuple[float, float], depth: float) -> np.ndarray:
    """Each point and the point `depth` m behind it, away from origin (an obstacle seen from one side)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) == 0:
        return points
    away = points - origin
    away /= np.maximum(np.hypot(*away.T), 1e-9)[:, None]
    return np.concatenate([points, points + depth * away])
