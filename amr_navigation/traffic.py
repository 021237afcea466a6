"""Traffic rules for a robot among others, as plain classes and functions (no ROS).

The navigator of one robot runs them on every observation it drives with the path follower
(amr_navigation.loop.NavigationLoop with a `Traffic`); they decide, the path follower follows:

1. **Stop for what is in the way.** The scan's returns are put on the map with the estimate; a
   return farther than `map_tolerance` from every mapped obstacle is *unmapped* (another robot, a
   person, a box). The path ahead is checked against the unmapped returns in front of the robot: the
   free travel is the arc length to the first path point whose disc (`robot_radius` +
   `path_clearance`) would touch `min_returns` of them. The speed rule (`obstacle_speed`, a pure
   function, as nav2's regulated pure pursuit slows near obstacles) caps the path follower's speed:
   0 within `stop_distance` of free travel, rising linearly to no cap at `slow_distance`; a stopped robot
   moves on once the free travel exceeds `stop_distance` by RESUME_MARGIN (not at the first noisy beam).
2. **Wait, then replan around it.** Stopped for `wait_time` with the obstacle still there, the robot
   plans again to its goal on a copy of the costmap with the unmapped returns marked (each return and
   a point one robot radius behind it along its beam, as discs of `mark_radius`, inflated as walls
   are: amr_planning's `Costmap.with_obstacles`), and follows that path. A failed plan (no way round)
   is tried again every `wait_time`. The marks are cleared once the scan sees through them (a beam at
   a mark's bearing reaching `clear_distance` beyond it): the robot then plans again on the map.
   **2b. Back off** from what no post explains: stopped for `yield_timeout` by unmapped returns while no robot on
   the board stands on its stretch of path (every plan around them failed), the robot drives to the nearest place
   `mark_range` from those returns (in a dead end shorter than that: as far from them as the dead end goes, if
   that is two radii farther than it stands), waits there `yield_timeout`, then plans to its goal again. What stands
   there may be a robot whose filter is not sure where it is (it posts no position, so rules 3-7 do not see it); in a
   dead end the robot waiting at its mouth blocks both its way out and the view its filter needs.
3. **Right of way** (two robots face to face in a corridor one robot wide, or crossing). Every robot
   posts on a `TrafficBoard` what the others need: its name, its priority (its place in the world's
   `robots` list: the first has the right of way over all), its estimate (None while not localized),
   the next `conflict_distance` m of its path, which robot blocks it (another's posted centre within
   2 `robot_radius` + `path_clearance` of that stretch of path, in front of it), whom it yields to, and
   whether it is passive (its goal reached, or waiting aside). A robot **yields** to robot B when B is
   blocked by it and

   - it is blocked by B too and B has the right of way (lower priority number), or B has posted that
     it cannot yield (no place to wait), or
   - it is passive (at its goal, or already waiting aside for another): a passive robot makes way for
     anyone it blocks.

   Yielding: on the costmap with the other robots' discs marked, the nearest cell (breadth-first over
   the cells where the robot fits, at most `yield_search` m of steps) that is at least 2
   `robot_radius` + `yield_clearance` from the stretches of path of every robot it blocks, and from
   their centres, is the place to wait; the robot is handed a path there (a detour: the navigator keeps
   its goal and does not count the detour as straying), waits there (zero speed) until none of them
   needs the place (their posted paths pass more than that distance away and they are farther than
   that), or until they have stood still for `yield_timeout` s, then plans to its goal again. Without such a place it
   posts `cannot_yield` (and looks again after `wait_time`), and the other robot yields instead. The robot with the
   right of way, blocked by a robot that yields to it, waits without replanning around it (for at most
   `yield_timeout`).
   A robot waiting aside that a robot it gives way to finds in its way again (that robot's new path passes
   the place) goes aside again for it.
4. **Way out** (a passive robot boxed in). A robot parked at its goal in a dead end, or in a corridor one
   robot wide, blocks a robot that must pass it, and the only way to any place aside is where that robot
   stands: the rule above finds no place. It then looks again as if the robots it blocks were not there
   (they can make way; the place must still be that distance from their paths and centres), and takes a
   place beyond them. Driving there it holds while a robot stands on its way (within 2 `robot_radius` +
   `path_clearance` of the next `conflict_distance` m), and posts that robot as its blocker and itself as
   `cannot_yield`, not passive: the blocked robot is then blocked by a robot that cannot yield, and by
   rule 3 goes aside, off the boxed-in robot's way out (and its place). Once the boxed-in robot has
   arrived, the other is done waiting (its way is free; if the place turns out to lie on its new path,
   the boxed-in robot goes aside again for it); the boxed-in robot goes back only when that robot no
   longer waits aside for it and its posted path no longer comes near the way back (it has passed), so
   the two do not meet again at the goal. While driving aside a robot always posts the rest of its
   detour (robots waiting for it to pass see it), and the post of a robot done waiting aside carries its
   way back until it has a new plan.

   Where it holds: a dead end or a corridor with a junction, a pocket or a room within `yield_search` m of
   steps beyond the blocked robot, on the far side from the boxed-in one (the boxed-in robot's place), and
   a second branch, or the corridor farther back, for the blocked robot to wait in off that way. Rooms
   need none of it (there is a place aside within reach). A corridor with no branch within reach on the
   blocked robot's side is not resolved: both post `cannot_yield` and wait (the boxed-in robot gives up
   after `yield_timeout` and parks again, then tries again). tests/navigation/test_traffic.py runs a robot
   parked in a dead end with the other coming in to a goal behind it, in either order of the list.
5. **Search farther** (neither can give way within reach). Two robots blocked by each other that both post
   `cannot_yield` (the lower-priority one found no place within `yield_search`, then the other found none
   either) would wait for ever. The lower-priority one then searches again with no bound but the map, and
   past robots parked at their goals (they make way for it by rule 3 when it holds before them on its way;
   the place is still that distance from them), the place still that distance from the other's path and
   centre; it goes there as in rule 3 while the other holds (at most `yield_timeout`, then it follows, held
   back by rule 1). Should that fail too, the other does the same once its own search has failed for
   `wait_time` (the lower-priority one has had its turn first). Both look again every `wait_time` and a robot
   clears its flag on the observation it looks again, so each reads the other's `cannot_yield` as seen
   within the last `wait_time`. Why this resolves a tree maze (one way between any two cells): the stretch
   between the two splits the free space into two sides; the other's path runs through this robot's side to
   its goal, so a place on this side is any cell that far from that path: a branch off it, or the dead end
   beyond the other's goal (then the other parks at its goal in front of this robot, and rules 3 and 4 get
   this one out). The bound, and the parked robots taken as walls, only made the search give up early; the
   nearest place is still taken (breadth-first). Not resolved: neither side has such a cell anywhere (each a
   bare corridor ending at the other's goal: no swap is possible), and a robot on the way that is not parked
   (exploring, or itself giving way) still counts as a wall. tests/navigation/test_traffic.py runs a corridor
   whose only place aside is a pocket 5 m behind the lower-priority robot (neither moves without the rule).

6. **Make room** (a robot behind the one that must give way). When neither robot of a pair could give way nearby
   (rule 5) and the farther search fails too because every way to a place aside is where a robot stands that it
   does not give way to (one waiting behind it in a corridor one robot wide, itself blocked by this robot), the
   robot searching farther looks last for a place past such robots (not where one stands); earlier, before rule
   5, the other robot gives way instead (letting the lower-priority robot push past bystanders first made a
   six-robot perfect maze cycle: 0/6 at goal). Driving there it holds before the robot on its way and posts it
   as its blocker, unable to give way: that robot, blocked by one that cannot give way, goes aside first
   (rule 3), and on it goes; it does not go aside for the robots it passes. Without it a convoy in a corridor stands
   for good: every search treats the robot behind as a wall, and planning around fails in a corridor.
   tests/navigation/test_traffic.py runs two robots in a row meeting a third.

7. **Knot** (three or more robots blocked in a cycle). Robots each blocked by the next, the last by the first
   (a by b, b by c, c by a: three at a junction of one-wide corridors, each facing the next one's centre), are not
   a pair blocked by each other, so rule 3 never fires for any of them. The robot of the lowest priority in the
   cycle (none of its robots passive or already giving way) gives way to the robot it blocks, as in rule 3 (a
   place off that robot's path and centre, that robot holding meanwhile); with no place within `yield_search` for
   `wait_time` it searches farther (rule 5). Every robot follows the chain of `blocked_by` on the board, so each
   sees the same cycle and only its last moves. tests/navigation/test_traffic.py builds such a knot on the board.

Two robots face to face in a one-wide corridor with a side pocket or a junction on either robot's
side of the meeting point cannot deadlock: both are blocked by each other, exactly one yields (the
other's rule is the same rule with the roles swapped), the yielding one has a place (the pocket, or
the corridor behind it beyond the junction) or says it has none, and then the other has one (the
pocket lies on its side). tests/navigation/test_traffic.py runs that world in the simulator.

What a robot needs of the others is exactly its board post (`TrafficPost`). At library level the
board is one object shared by the robots' navigators (amr_evaluation.fleet_navigation). Through ROS it
is a topic shared by the fleet (absolute name `/traffic`, amr_interfaces/TrafficPost, every robot's
navigator node publishing its post there and subscribing to everyone's: amr_navigation.navigator_node with
`traffic: true`, amr_navigation.traffic_messages), not a per-robot topic.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np
from scipy.ndimage import distance_transform_edt, label

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


# -- pure functions ----------------------------------------------------------------------------


def obstacle_speed(free_travel: float, stop_distance: float, slow_distance: float, speed: float) -> float:
    """The speed cap for `free_travel` m of path before an obstacle: 0 at or below stop_distance, `speed` at
    or beyond slow_distance, linear between (infinite free travel: `speed`)."""
    if not free_travel > stop_distance:
        return 0.0
    if free_travel >= slow_distance:
        return speed
    return speed * (free_travel - stop_distance) / (slow_distance - stop_distance)


def scan_points(scan: ScanData, pose: tuple[float, float, float], lidar_x: float) -> tuple[np.ndarray, np.ndarray]:
    """(returns (N, 2) in the map frame, the same returns (N, 2) in the robot frame) of the valid beams
    (REP 117: NaN, inf and out-of-range dropped)."""
    ranges = np.asarray(scan.ranges, dtype=float)
    valid = np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges <= scan.range_max)
    angles = scan.angle_min + scan.angle_increment * np.flatnonzero(valid)
    r = ranges[valid]
    local = np.stack([lidar_x + r * np.cos(angles), r * np.sin(angles)], axis=1)
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    world = np.stack([x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]], axis=1)
    return world, local


def unmapped(costmap: Costmap, points: np.ndarray, tolerance: float) -> np.ndarray:
    """True for points (N, 2) farther than `tolerance` from every obstacle of the costmap's map (points off
    the map are taken as mapped: nothing is known there)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    row, col = costmap.grid.world_to_cell(points[:, 0], points[:, 1])
    inside = costmap.grid.inside(row, col)
    result = np.zeros(len(points), dtype=bool)
    result[inside] = costmap.clearance[row[inside], col[inside]] > tolerance
    return result


def path_ahead(path: np.ndarray, x: float, y: float, length: float, spacing: float = 0.025) -> np.ndarray:
    """The stretch of `path` (N, 2) from the point closest to (x, y) on, `length` m long, resampled every
    `spacing` m (its first point is that closest point)."""
    path = np.asarray(path, dtype=float)
    if len(path) == 1:
        return path.copy()
    starts, vectors = path[:-1], np.diff(path, axis=0)
    lengths = np.hypot(*vectors.T)
    rel = np.array([x, y]) - starts
    t = np.clip(
        np.divide((rel * vectors).sum(axis=1), lengths**2, out=np.zeros_like(lengths), where=lengths > 0), 0.0, 1.0
    )
    distances = np.hypot(*(starts + t[:, None] * vectors - (x, y)).T)
    best = int(np.argmin(distances))
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    begin = arc[best] + t[best] * lengths[best]
    end = min(arc[-1], begin + length)
    s = np.append(np.arange(begin, end, spacing), end)
    return np.stack([np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])], axis=1)


def free_travel(stretch: np.ndarray, points: np.ndarray, reach: float, min_returns: int) -> float:
    """m along `stretch` (M, 2), a path resampled from the robot on, before its disc of radius `reach` touches
    `min_returns` of `points` (N, 2); inf when fewer are ever touched."""
    if len(points) < min_returns or len(stretch) == 0:
        return math.inf
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(stretch, axis=0).T))])
    distance = np.hypot(stretch[:, None, 0] - points[None, :, 0], stretch[:, None, 1] - points[None, :, 1])
    touched = distance <= reach
    hit = touched.any(axis=0)
    if np.count_nonzero(hit) < min_returns:
        return math.inf
    first = np.argmax(touched[:, hit], axis=0)  # the first sample touching each hit return
    return float(np.sort(arc[first])[min_returns - 1])


def min_distance(points: np.ndarray, x: float, y: float) -> float:
    """m from (x, y) to the nearest of points (N, 2); inf for none."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return float(np.hypot(points[:, 0] - x, points[:, 1] - y).min()) if len(points) else math.inf


def place_aside(
    costmap: Costmap, start: tuple[float, float], avoid: np.ndarray, distance: float, search: float
) -> tuple[float, float] | None:
    """The nearest cell (breadth-first, 8-connected, over the cells where the robot fits) at least `distance`
    from every point of `avoid` (N, 2) (others' paths and centres), within `search` m of steps; None if none.
    Cells clear of the safety margin are preferred (searched first); else any non-lethal cell."""
    avoid = np.asarray(avoid, dtype=float).reshape(-1, 2)
    # points farther than that from every cell the search can reach change nothing: left out (the cost is per point)
    avoid = avoid[
        np.abs(avoid - np.asarray(start, dtype=float)).max(axis=1) <= search + distance + 2.0 * costmap.grid.resolution
    ]
    for passable in (~costmap.inflated, ~costmap.lethal):
        found = _breadth_first(costmap, passable, start, avoid, distance, search)
        if found is not None:
            return found
    return None


def farthest_place(
    costmap: Costmap, start: tuple[float, float], avoid: np.ndarray
) -> tuple[tuple[float, float], float] | None:
    """The cell reachable from `start` (4-connected over the cells where the robot fits; those clear of the safety
    margin if the start has any such neighbour) farthest from every point of `avoid` (N, 2), and that distance (m);
    None if `avoid` is empty or the start is off the map. Where no place lies a given distance away (a dead end
    shorter than that), the way as far as it goes."""
    avoid = np.asarray(avoid, dtype=float).reshape(-1, 2)
    grid = costmap.grid
    row, col = (int(v) for v in grid.world_to_cell(start[0], start[1]))
    if len(avoid) == 0 or not grid.inside(row, col):
        return None
    seeds = np.zeros(costmap.shape, dtype=bool)
    rows, cols = grid.world_to_cell(avoid[:, 0], avoid[:, 1])
    inside = grid.inside(rows, cols)
    seeds[np.asarray(rows)[inside], np.asarray(cols)[inside]] = True
    if not seeds.any():
        return None
    away = distance_transform_edt(~seeds) * grid.resolution
    for passable in (~costmap.inflated, ~costmap.lethal):
        walk = passable.copy()
        walk[row, col] = True  # the robot stands where it stands, whatever the marks say
        parts, _ = label(walk)
        reach = parts == parts[row, col]
        if reach.sum() > 1:
            break
    score = np.where(reach, away, -1.0)
    best = np.unravel_index(int(np.argmax(score)), score.shape)
    x, y = costmap.centre(best[0], best[1])
    return (float(x), float(y)), float(score[best])


def _breadth_first(costmap, passable, start, avoid, distance, search):
    grid = costmap.grid
    row, col = (int(v) for v in grid.world_to_cell(start[0], start[1]))
    if not grid.inside(row, col):
        return None
    rows, cols = passable.shape
    # far enough from every avoided point: one distance transform-free test on all cells at once
    reach = int(math.ceil(search / grid.resolution))
    r0, r1 = max(0, row - reach), min(rows, row + reach + 1)
    c0, c1 = max(0, col - reach), min(cols, col + reach + 1)
    rr, cc = np.mgrid[r0:r1, c0:c1]
    centres = costmap.centre(rr, cc)
    clear = np.ones(rr.shape, dtype=bool)
    for chunk in np.array_split(avoid, max(1, len(avoid) // 64)) if len(avoid) else ():
        gap = np.hypot(centres[..., None, 0] - chunk[None, None, :, 0], centres[..., None, 1] - chunk[None, None, :, 1])
        clear &= (gap >= distance).all(axis=-1)
    ok = passable[r0:r1, c0:c1] & clear
    walk = passable[r0:r1, c0:c1]
    seen = np.zeros(walk.shape, dtype=bool)
    sr, sc = row - r0, col - c0
    queue = deque([(sr, sc)])
    seen[sr, sc] = True
    height, width = walk.shape
    while queue:
        i, j = queue.popleft()
        if ok[i, j]:
            x, y = costmap.centre(i + r0, j + c0)
            return float(x), float(y)
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)):
            a, b = i + di, j + dj
            if 0 <= a < height and 0 <= b < width and not seen[a, b] and walk[a, b]:
                seen[a, b] = True
                queue.append((a, b))
    return None


# -- the board ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrafficPost:
    """What one robot tells the others, once per observation."""

    name: str
    priority: int
    """lower is first: its index in the world's robots list."""
    pose: tuple[float, float, float] | None = None
    """the estimate in the map frame; None while not localized."""
    path: np.ndarray | None = None
    """(M, 2) the rest of the path it follows (from its closest point on); None without one."""
    blocked_by: str = ""
    """the robot whose centre stands on that stretch of path, in front of it ('' none)."""
    yielding_to: tuple[str, ...] = ()
    passive: bool = False
    """at its goal or waiting aside: it makes way for anyone it blocks."""
    cannot_yield: bool = False
    """it should yield but found no place to wait: the other robot yields instead."""


class TrafficBoard:
    """Every robot's latest post (at library level one object shared by the fleet's navigators; through ROS
    a topic in a namespace the fleet shares)."""

    def __init__(self) -> None:
        self._posts: dict[str, TrafficPost] = {}

    def post(self, post: TrafficPost) -> None:
        self._posts[post.name] = post

    def others(self, name: str) -> list[TrafficPost]:
        return [post for other, post in self._posts.items() if other != name]

    def get(self, name: str) -> TrafficPost | None:
        return self._posts.get(name)


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

    # -- planner ---------------------------------------------------------------------------------

    def planner(self, planner: Planner) -> Planner:
        """The planner to plan to the goal with: the map's, or one with the current marks."""
        if len(self.marks) == 0:
            return planner
        return planner.with_obstacles(self.marks, self.config.mark_radius)

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
