"""The wall-following controller of seed 002, as a plain class (no ROS).

Each call to :meth:`WallFollower.compute` takes one synchronized LiDAR scan,
the odometry twist and the stamp, and returns the velocity command. The
state machine (``WallFollower.state``):

* ``SEARCH``: no wall yet; drive straight until the followed wall shows up
  (a wall met ahead is turned from so that it ends up on the followed side).
* ``FOLLOW``: keep the followed wall at ``target_wall_distance`` with PD
  control on the distance error e = d - target,
  ``w = s (kp e + kd de/dt)`` with s = +1 for the left wall, -1 for the right,
  saturated at ``angular_limit``. d is the distance to the line fitted to the
  side window; where the wall is not straight only e < 0 is corrected. Along a
  straight wall de/dt = s v sin(skew) from the filtered skew (SkewFilter), else
  over the real time between stamps (optionally low-passed).
* ``CORNER``: the followed wall ended (an opening on that side): drive on until
  the rotation centre is ``target_wall_distance`` past the wall's measured end
  (where no wall was fitted since the last turn, the edge of the solid passed on
  that side, such as a thin wall's end face; ``corner_advance`` past where it was
  lost if neither is seen), then turn towards the opening.
* ``APPROACH``: a front return closer than ``front_threshold`` at a corner:
  creep on at ``stabilize_speed`` until the rotation centre is
  ``target_wall_distance`` from the wall ahead (a threshold above that, as on
  the real robot, would otherwise leave it off-centre after the turn).
* ``TURN_LEFT`` / ``TURN_RIGHT``: turn in place 90 deg; ``TURN_AROUND``: 180
  deg at a dead end. The turn is chosen by comparing the side distances, read
  square to the walls: towards the followed side if open (while following
  a wall; while searching, away from it first), else the other side if open,
  else around. A turn ends when odometry says the angle is done (nominal plus
  the skew against the walls, so it ends square; the skew is carried through a
  square turn by odometry, a quarter turn on) and the narrow
  window ahead reads ``turn_exit_distance``, or, for a square turn, the way
  ahead is open (``open_travel_distance``); waiting for room, at most
  TURN_OVERSHOOT past the angle (or after ``turn_timeout_factor`` times its
  nominal duration).
* ``STABILIZE``: the seed's Fixed_Front: straight ahead at
  ``stabilize_speed`` for ``stabilize_time``, then on until the followed wall
  is found (``FOLLOW``) or ``corner_exit_distance`` is driven (``SEARCH``).
* ``AVOID``: safety net in every moving state: if driving straight on would
  bring the disc footprint (widened by half the ``safety_margin`` on each
  side) within ``safety_margin`` of a return, turn in place away from it (a
  disc turning in place touches nothing new).

Symmetric junctions (both sides open and within ``symmetric_tolerance``) and
the direction of a dead-end turn between equal sides are drawn from a
``random.Random(random_seed)``, so runs are reproducible.

Bad data never raises and never yields a NaN command: see :class:`Issue`.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from amr_control.scan_sectors import Footprint, LineFit, Readings, ScanData, SectorReader, Sectors
from amr_control.wall_follower_config import WallFollowerConfig

PLAUSIBLE_FACTOR = 2.0
"""Odometry beyond this many times the fastest commanded speed is treated as corrupt."""
ANGLE_FLOOR = math.radians(1.0)
"""No single line fit gives the walls' direction better than this (rad, standard deviation)."""
WALL_WANDER = 0.1
"""rad per sqrt(m): how fast the walls' direction may wander as the robot drives (bends, curves)."""
TURN_ERROR = 0.05
"""Share of an angle turned that the odometry heading may be wrong by (wheel slip)."""
SKEW_GATE = 3.0
"""A fit this many standard deviations from the estimate (and at least GATE_MIN off) is an outlier..."""
GATE_MIN = math.radians(10.0)
GATE_PATIENCE = 3
"""... and this many in a row are another wall: the estimate starts afresh from the last."""
STALE_SKEW = math.radians(10.0)
"""An estimate less certain than this (standard deviation) is not used."""
OPEN_STEP_DEG = 5.0
"""Spacing of the candidate directions of a turn."""
OPEN_AIM = math.radians(30.0)
"""A turn aims this far into an open run of directions from its edge on the followed side."""
BEHIND_HAND = math.radians(10.0)
"""Past the abeam on the followed side by this, with the hand on the wall, a direction leads back."""
TURN_OVERSHOOT = math.radians(30.0)
"""A turn waiting for room ahead ends at most this far past its angle."""
NOISE_ALLOWANCE = 0.03
"""m: a direction the disc clears by less than this still counts as open (LiDAR noise up to 3 cm
makes a 0.3 m corridor look narrower than the robot); the driving itself keeps the full margins."""
SQUARE_SNAP = math.radians(20.0)
"""An open direction within this of +-90 deg is a square corner: turn 90 deg, corrected by the skew."""
SEARCH_TURN = math.radians(30.0)
"""Searching, a nearest wall further off the heading than this is faced by turning in place."""


class State(StrEnum):
    SEARCH = "SEARCH"
    FOLLOW = "FOLLOW"
    CORNER = "CORNER"
    APPROACH = "APPROACH"
    TURN_LEFT = "TURN_LEFT"
    TURN_RIGHT = "TURN_RIGHT"
    TURN_AROUND = "TURN_AROUND"
    STABILIZE = "STABILIZE"
    AVOID = "AVOID"


MOVING = (State.SEARCH, State.FOLLOW, State.CORNER, State.APPROACH, State.STABILIZE)
TURNING = (State.TURN_LEFT, State.TURN_RIGHT, State.TURN_AROUND)


class Issue(StrEnum):
    """Why a command is not a plain one; the value is the log message."""

    BAD_SCAN = "unusable scan (empty, bad angles or a window without beams): stopping"
    NO_VALID_BEAMS = "no valid beam in the scan (all NaN or out of range): stopping"
    BAD_STAMP = "non-finite stamp: time-based terms frozen"
    REPEATED_STAMP = "repeated stamp: time-based terms frozen"
    TIME_WENT_BACKWARDS = "stamp went backwards: derivative reset"
    TIME_GAP = "long gap between stamps: derivative reset"
    BAD_ODOMETRY = "odometry non-finite or implausible: using the last command instead"


@dataclass(frozen=True)
class Command:
    """A velocity command (m/s, rad/s, counter-clockwise positive) and what went wrong, if anything."""

    v: float
    w: float
    issues: tuple[Issue, ...] = ()

    @property
    def ok(self) -> bool:
        return not self.issues

    def describe(self) -> str:
        return "; ".join(issue.value for issue in self.issues)


@dataclass(frozen=True)
class Measurements:
    """The last scan's distances (m from the LiDAR; inf = nothing seen), for logs and plots."""

    front: float = math.inf
    left: float = math.inf
    right: float = math.inf
    wall_distance: float = math.inf
    """to the followed wall"""
    followed_wall: str = "right"
    clearance: float = math.inf
    """straight-ahead travel left before the footprint touches something"""


class SkewFilter:
    """The heading error against the walls (the skew), from side-wall fits averaged along the way.

    The skew squares every turn (90 deg corrected by it), so its error ends up in the heading
    the robot enters the next corridor with. One fit's direction is poor under range noise
    (Sectors.direction_half_width): at 3 cm LiDAR noise a +-40 deg window 0.175 m from a wall
    still scatters by about 3 deg. The filter carries the skew along with the odometry (turning
    by a counter-clockwise changes it by -a) as a one-state Kalman filter: each fit counts by
    its own standard error (LineFit.angle_std, at least ANGLE_FLOOR); the estimate ages with
    the distance driven (WALL_WANDER: walls may bend) and the angle turned (TURN_ERROR: odometry
    heading error). A fit further than SKEW_GATE sigma (and GATE_MIN) from the estimate is an
    outlier and ignored, unless GATE_PATIENCE in a row are (another wall): the estimate then
    starts afresh from the last one. A tentative fit (the other side's wall) is only used when
    it agrees.
    """

    def __init__(self) -> None:
        self.forget()

    def forget(self) -> None:
        """No estimate (after a turn in place the walls alongside are other walls)."""
        self._skew: float | None = None
        self._variance = math.inf
        self._misses = 0

    def move(self, distance: float, turn: float) -> None:
        """The robot drove ``distance`` m and turned ``turn`` rad (counter-clockwise positive) by odometry."""
        if self._skew is not None:
            self._skew = _half_turn(self._skew - turn)
            self._variance += WALL_WANDER**2 * abs(distance) + (TURN_ERROR * turn) ** 2

    def square(self) -> None:
        """After a square turn in place (90 or 180 deg by odometry): the walls alongside are square to
        the ones before, so the estimate carried through the turn holds up to a quarter turn."""
        if self._skew is not None:
            self._skew = math.remainder(self._skew, 0.5 * math.pi)

    def measure(self, fit: LineFit, tentative: bool = False) -> None:
        """A fitted wall; ``tentative``: only used if it agrees with the estimate (the other side's wall)."""
        r = max(fit.angle_std, ANGLE_FLOOR) ** 2
        if self._skew is None:
            if not tentative:
                self._skew, self._variance, self._misses = fit.angle, r, 0
            return
        innovation = _half_turn(fit.angle - self._skew)
        if abs(innovation) > max(SKEW_GATE * math.sqrt(self._variance + r), GATE_MIN):
            if not tentative:
                self._misses += 1
                if self._misses >= GATE_PATIENCE:
                    self._skew, self._variance, self._misses = fit.angle, r, 0
            return
        if not tentative:
            self._misses = 0
        gain = self._variance / (self._variance + r)
        self._skew = _half_turn(self._skew + gain * innovation)
        self._variance *= 1.0 - gain

    @property
    def skew(self) -> float | None:
        """rad, the heading error against the walls, as LineFit.angle (positive: the robot is turned
        clockwise of them); None without an estimate or when it is staler than STALE_SKEW."""
        if self._skew is None or self._variance > STALE_SKEW**2:
            return None
        return self._skew

    @property
    def std(self) -> float:
        """rad, the estimate's standard deviation (inf without one)."""
        return math.sqrt(self._variance)


class WallFollower:
    """Seed 002's wall follower: construct from a parameter dict or a WallFollowerConfig."""

    def __init__(self, params: Mapping[str, Any] | WallFollowerConfig | None = None) -> None:
        if params is None:
            config = WallFollowerConfig()
        elif isinstance(params, WallFollowerConfig):
            config = params
        else:
            config = WallFollowerConfig.from_params(params)
        self._use(config)
        self.reset()

    def _use(self, config: WallFollowerConfig) -> None:
        """Take a configuration and what derives from it; the state machine is left as it is."""
        self.config = config
        self._reader = SectorReader(
            Sectors(
                math.radians(config.front_window_deg),
                math.radians(config.side_window_deg),
                math.radians(config.abeam_window_deg),
                direction_half_width=math.radians(config.wall_direction_window_deg),
            ),
            Footprint(config.robot_radius, config.lidar_x, 0.5 * config.safety_margin),
            config.scan_median_beams,
        )
        step = math.radians(OPEN_STEP_DEG)
        sweep = math.radians(config.open_sweep_deg)
        self._candidates = np.arange(-sweep, sweep + 0.5 * step, step)
        self._max_v = max(config.linear_speed, config.stabilize_speed)
        # Front distance (from the LiDAR) at which the rotation centre is target_wall_distance from
        # the wall ahead: turning there leaves the robot on its line in the new corridor.
        self._pivot_distance = config.target_wall_distance - config.lidar_x
        self._max_w = max(config.turn_speed, config.angular_limit)

    # -- public ----------------------------------------------------------------------------

    def reset(self) -> None:
        """Back to the initial state (lifecycle activate, simulator reset); the RNG is reseeded."""
        self._rng = random.Random(self.config.random_seed)
        self._followed = self._draw_side() if self.config.preferred_wall == "random" else self.config.preferred_wall
        self._state = State.SEARCH
        self._search_aimed = False
        self._turn_needs_room = True
        self._resume = (State.SEARCH, 0.0, 0.0)  # (state, state_time, traveled) AVOID returns to
        self._turn_sign = 0.0
        self._turn_angle = 0.0
        self._square_turn = False  # whether the turn in place is a square one (the skew is carried through it)
        self._skew_filter = SkewFilter()
        self._skew = 0.0  # the heading error against the walls (SkewFilter), 0 when unknown
        self._skew_seen = False  # whether it is known and this scan has a fitted wall
        self._state_time = 0.0
        self._traveled = 0.0
        self._turned = 0.0
        self._last_stamp: float | None = None
        self._last_error: float | None = None
        self._error_rate = 0.0
        self._straight = False  # whether the last PD error came from a fitted line
        self._tracking = False  # whether the last front block met the robot following a wall
        self._wall_line = math.inf  # the followed wall's distance from the LiDAR, last fitted while following
        self._side_edge = -math.inf  # SectorReader.side_edge since the last turn, carried along as the robot drives
        self._command = (0.0, 0.0)
        self._measurements = Measurements(followed_wall=self._followed)

    def reconfigure(self, config: WallFollowerConfig) -> None:
        """New parameters (a live `ros2 param set`) for the next scan, keeping the state the robot is in."""
        self._use(config)
        if config.preferred_wall != "random":
            self._followed = config.preferred_wall

    @property
    def state(self) -> str:
        """The state machine's state name."""
        return self._state.value

    @property
    def followed_wall(self) -> str:
        """'right' or 'left'."""
        return self._followed

    @property
    def measurements(self) -> Measurements:
        return self._measurements

    def compute(self, scan: ScanData, odometry_v: float, odometry_w: float, stamp: float) -> Command:
        """The command for one synchronized (scan, odometry) pair stamped ``stamp`` seconds."""
        issues: list[Issue] = []
        elapsed, rate_valid = self._advance_clock(stamp, issues)
        moved, rotation = self._motion(odometry_v, odometry_w, elapsed, issues)
        turned = abs(rotation)
        self._skew_filter.move(moved, rotation)

        readings = self._reader.read(scan)
        if isinstance(readings, str) or not self._windows_covered(readings):
            return self._stop(issues + [Issue.BAD_SCAN])
        if readings.usable_beams == 0:
            return self._stop(issues + [Issue.NO_VALID_BEAMS])

        self._state_time += elapsed
        self._traveled += moved
        self._turned += turned
        self._track_side_edge(moved)
        self._transition(readings)
        v, w = self._command_for(readings, elapsed, rate_valid)
        self._record(readings)
        return self._emit(v, w, issues)

    # -- time and motion -------------------------------------------------------------------

    def _advance_clock(self, stamp: float, issues: list[Issue]) -> tuple[float, bool]:
        """Seconds since the previous pair (0 if unknown) and whether the error rate may be updated."""
        stamp = _as_float(stamp)
        if not math.isfinite(stamp):
            issues.append(Issue.BAD_STAMP)
            return 0.0, False
        last, self._last_stamp = self._last_stamp, stamp
        if last is None:
            return 0.0, False
        dt = stamp - last
        if dt == 0.0:
            issues.append(Issue.REPEATED_STAMP)
            return 0.0, False
        if dt < 0.0:
            issues.append(Issue.TIME_WENT_BACKWARDS)
            self._last_error = None
            return 0.0, False
        if dt > self.config.max_stamp_gap:
            issues.append(Issue.TIME_GAP)
            self._last_error = None
            return self.config.max_stamp_gap, False
        return dt, True

    def _motion(self, v: float, w: float, elapsed: float, issues: list[Issue]) -> tuple[float, float]:
        """Distance driven and angle turned (counter-clockwise positive) since the previous pair, from
        odometry when it is sane."""
        v, w = _as_float(v), _as_float(w)
        sane = (
            math.isfinite(v)
            and math.isfinite(w)
            and abs(v) <= PLAUSIBLE_FACTOR * self._max_v
            and abs(w) <= PLAUSIBLE_FACTOR * self._max_w
        )
        if not sane:
            issues.append(Issue.BAD_ODOMETRY)
            v, w = self._command
        return abs(v) * elapsed, w * elapsed

    # -- the state machine -----------------------------------------------------------------

    def _transition(self, r: Readings) -> None:
        """Move the state machine on for this scan; the safety checks come last so they always win."""
        c = self.config
        self._update_skew(r)
        state = self._state
        lost = c.wall_lost_distance + (c.wall_lost_hysteresis if state == State.FOLLOW else 0.0)
        present = self._abeam(r, self._followed) <= lost
        if state == State.AVOID:
            self._avoid_step(r)
        elif state in TURNING:
            self._turn_step(r)
        elif state == State.STABILIZE:
            self._stabilize_step(present)
        elif state == State.SEARCH:
            self._search_step(r, present)
        elif state == State.CORNER:
            self._corner_step(present)
        elif state == State.APPROACH:
            self._approach_step(r)
        else:
            self._follow_step(r, present)
        if self._state in MOVING:
            self._safety_step(r, present)

    def _avoid_step(self, r: Readings) -> None:
        """AVOID: back to the state it interrupted once the clearance is twice the safety margin."""
        if r.clearance >= 2.0 * self.config.safety_margin:
            self._state, self._state_time, self._traveled = self._resume
            self._last_error = None

    def _turn_step(self, r: Readings) -> None:
        """Turning in place: STABILIZE once the angle is turned with room ahead, or on the turn's timeout."""
        c = self.config
        turned = self._turned >= self._turn_angle
        # A square turn facing an open way (the footprint could drive open_travel_distance along
        # it) ends at its angle: a corridor that leaves less than turn_exit_distance ahead (a
        # T-junction or a one-cell side passage of a 0.35 m maze, under the real configuration's
        # 0.515 m) is still the corridor the turn was square to. Waiting for room there ran the
        # turn TURN_OVERSHOOT past square, and the next turns inherited the 30 deg.
        room = (
            not self._turn_needs_room
            or r.ahead >= c.turn_exit_distance
            or (turned and self._square_turn and self._open_ahead())
        )
        # Never more than TURN_OVERSHOOT past the angle waiting for room: in a narrow bend
        # the way back is the first direction with that much room.
        done = turned and (room or self._turned >= self._turn_angle + TURN_OVERSHOOT)
        if done or self._state_time >= c.turn_timeout_factor * self._turn_angle / c.turn_speed:
            if self._square_turn:
                self._skew_filter.square()
            self._enter(State.STABILIZE)

    def _stabilize_step(self, present: bool) -> None:
        """STABILIZE: after stabilize_time, FOLLOW the wall if it is there, else SEARCH past corner_exit_distance."""
        c = self.config
        if self._state_time >= c.stabilize_time:
            if present:
                self._enter(State.FOLLOW)
            elif self._traveled >= c.corner_exit_distance:
                self._enter(State.SEARCH)

    def _search_step(self, r: Readings, present: bool) -> None:
        """SEARCH: FOLLOW a wall found on the followed side; else, once, aim at the nearest wall."""
        if present:
            self._enter(State.FOLLOW)
        elif not self._search_aimed:  # settle on the nearest wall once, then drive straight to it
            self._search_aimed = True
            self._aim_at_nearest_wall(r)

    def _aim_at_nearest_wall(self, r: Readings) -> None:
        """Turn in place towards the nearest wall (far: face it; near and nothing ahead: put it on the followed
        side) when that is more than SEARCH_TURN off the heading."""
        c = self.config
        bearing, distance = self._reader.nearest()
        if c.wall_lost_distance < distance < math.inf:  # far: face it
            turn = bearing
        elif distance < math.inf and r.front > c.wall_lost_distance:
            # Near, not on the followed side, nothing ahead to turn at: put it on that side.
            abeam = -0.5 * math.pi if self._followed == "right" else 0.5 * math.pi
            turn = math.remainder(bearing - abeam, 2.0 * math.pi)
        else:  # among walls: the turns at the wall ahead handle it
            turn = 0.0
        if abs(turn) > SEARCH_TURN:
            self._start_turn(State.TURN_LEFT if turn > 0.0 else State.TURN_RIGHT, angle=abs(turn))
            self._turn_needs_room = False

    def _corner_step(self, present: bool) -> None:
        """CORNER (past the followed wall's end): FOLLOW if the wall is back, else turn into the opening once there."""
        if present:  # the opening was only a short gap
            self._enter(State.FOLLOW)
        elif self._corner_reached():
            self._turn_into_opening()

    def _approach_step(self, r: Readings) -> None:
        """APPROACH (a wall ahead at a corner): decide the turn at the pivot distance."""
        if r.front <= self._pivot_distance or self._traveled >= self.config.front_threshold - self._pivot_distance:
            self._decide_turn(r)

    def _follow_step(self, r: Readings, present: bool) -> None:
        """FOLLOW: CORNER when the followed wall ends, else keep its fitted line."""
        if not present:  # the followed wall ended
            self._enter(State.CORNER)
        else:
            fit = self._fit(r, self._followed)
            if fit is not None:
                self._wall_line = fit.distance

    def _safety_step(self, r: Readings, present: bool) -> None:
        """While moving: a wall ahead starts a turn (or APPROACH to a corner), a return within the safety margin
        AVOID (turning away from it)."""
        c = self.config
        if r.front < c.front_threshold and self._state != State.APPROACH and not self._committed(r):
            # Following a wall (or just past its end) rather than looking for one?
            self._tracking = present or self._state == State.CORNER
            dead_end = self._open_direction(self._followed == "right", hand_on_wall=present) is None
            if dead_end or r.front <= self._pivot_distance:
                self._decide_turn(r)
            else:  # a corner: turn where the robot will be centred in the new corridor
                self._enter(State.APPROACH)
        elif r.clearance < c.safety_margin:
            self._resume = (self._state, self._state_time, self._traveled)
            self._enter(State.AVOID)
            self._turn_sign = -1.0 if r.clearance_side > 0 else 1.0

    def _corner_reached(self) -> bool:
        """Whether the robot, past the end of the followed wall, is where it turns into the opening.

        Where the wall's end is seen (SectorReader.wall_end, in the walls' frame by the skew):
        once the rotation centre is target_wall_distance past it, so that the turn leaves the
        robot on its line in the new corridor. Noise-free that is where corner_advance past the
        point the wall was lost puts it; under noise the abeam window reads the wall's end late
        (a robot skewed 10 deg towards the wall saw it 18 cm late, and then turned back out of
        the overshot side corridor), the measured end does not. Where no wall was fitted since the
        last turn (a hairpin round a thin wall's end face just out of a turn): the edge of the solid
        passed on that side (_track_side_edge). Without either: corner_advance past the point the
        wall was lost.
        """
        c = self.config
        side = 1.0 if self._followed == "left" else -1.0
        if math.isfinite(self._wall_line):
            end = self._reader.wall_end(side, self._wall_line, self._skew)
        else:  # no wall fitted since the last turn: the end of whatever solid the robot passed on that side
            end = self._side_edge if math.isfinite(self._side_edge) else None
        if end is None:
            return self._traveled >= c.corner_advance
        return -end >= c.target_wall_distance

    def _track_side_edge(self, moved: float) -> None:
        """Where the solid passed on the followed side ends (SectorReader.side_edge), kept since the last
        turn: the furthest seen, carried back as the robot drives. A thin wall's end face can drop out
        of a scan (a 7 mm wall end-on from its own line: one beam, removed by the median), and the
        edge read on that scan alone jumped back to the wall before it, 0.4 m behind: an early turn."""
        self._side_edge -= moved * math.cos(self._skew)
        if self._state in MOVING:
            side = 1.0 if self._followed == "left" else -1.0
            edge = self._reader.side_edge(side, self.config.wall_lost_distance, self._skew)
            if edge is not None:
                self._side_edge = max(self._side_edge, edge)

    def _open_ahead(self) -> bool:
        """Whether the way straight ahead is open as a turn's candidate directions are (_open_direction):
        the footprint could drive open_travel_distance along it."""
        travel = self._reader.free_travel(np.zeros(1), NOISE_ALLOWANCE)
        return bool(travel[0] >= self.config.open_travel_distance)

    def _committed(self, r: Readings) -> bool:
        """Whether the robot, just out of a turn, is committed to the corridor it turned into.

        A turn ends facing a way ahead that is open (turn_exit_distance in the narrow window
        ahead). Skewed or off the corridor's line by a few cm, as noise leaves a robot after a
        turn in a 0.35 m corridor, the +-15 deg front window then still catches the edge of that
        corridor's mouth: that is no junction, and deciding there took the way back (the mouth of
        the corridor just left reads open beside the robot). While stabilizing with the way ahead
        open, a front return does not start a turn; the safety check still turns it off a return
        the footprint would touch.
        """
        return self._state == State.STABILIZE and r.ahead >= self.config.turn_exit_distance

    def _command_for(self, r: Readings, elapsed: float, rate_valid: bool) -> tuple[float, float]:
        c = self.config
        state = self._state
        if state == State.AVOID or state in TURNING:
            return 0.0, self._turn_sign * c.turn_speed
        if state == State.FOLLOW:
            return self._follow(r, elapsed, rate_valid)
        # Straight runs (STABILIZE, APPROACH, SEARCH, CORNER) keep parallel to a fitted wall if any.
        align = c.align_gain * self._skew if self._skew_seen else 0.0
        align = min(max(align, -c.angular_limit), c.angular_limit)
        slow = state in (State.STABILIZE, State.APPROACH)
        return (c.stabilize_speed if slow else c.linear_speed), align

    def _follow(self, r: Readings, elapsed: float, rate_valid: bool) -> tuple[float, float]:
        """PD on e = d - target: w = s (kp e + kd de/dt), saturated.

        d is the distance to the fitted line when the followed wall is straight. When it
        is not (its end, a corner, clutter in the window), the robot only steers away from
        returns nearer than the target: e = min(d_min - target, 0). Steering towards a
        corner would swing the robot round it, skewed, before the opening is even seen.
        """
        c = self.config
        straight = self._fit(r, self._followed) is not None
        distance = self._wall_distance(r)
        other = r.right if self._followed == "left" else r.left
        # In a corridor narrower than twice the target, keep to its middle instead.
        target = min(c.target_wall_distance, 0.5 * (distance + other))
        error = distance - target
        if not straight:
            error = min(error, 0.0)
        if straight != self._straight:  # a different measurement: no rate across the switch
            self._straight, self._last_error = straight, None
        if straight and self._skew_seen:
            # Along a straight wall de/dt = v sin(skew) (sign by side): the skew is carried by
            # odometry and corrected by every fit, where differentiating one noisy fit after another
            # at 3 cm LiDAR noise put about 1 rad/s of noise into w, and the heading wandered 10-15
            # deg off the corridor between corrections (late corner detection, turns off square).
            self._error_rate = (1.0 if self._followed == "left" else -1.0) * c.linear_speed * math.sin(self._skew)
        elif self._last_error is None:
            self._error_rate = 0.0
        elif rate_valid and elapsed > 0.0:
            raw = (error - self._last_error) / elapsed
            alpha = elapsed / (c.derivative_filter_time + elapsed)
            self._error_rate += alpha * (raw - self._error_rate)
        self._last_error = error
        side = 1.0 if self._followed == "left" else -1.0
        w = side * (c.kp * error + c.kd * self._error_rate)
        return c.linear_speed, min(max(w, -c.angular_limit), c.angular_limit)

    def _decide_turn(self, r: Readings) -> None:
        """Front blocked: turn by comparing the sides (seed 002 section 4.4).

        Keeping a hand on the wall: while following one, turn towards the followed side if
        it is open (the wall turns that way), else away from it; while still looking for a
        wall, turn away from the followed side first, which puts the wall ahead on it.
        """
        c = self.config
        left, right = self._sides_square(r)
        left_open = left > c.wall_lost_distance
        right_open = right > c.wall_lost_distance
        symmetric = (left == right) or abs(left - right) <= c.symmetric_tolerance
        if c.preferred_wall == "random" and left_open and right_open and symmetric:
            self._followed = self._draw_side()
        followed_open = left_open if self._followed == "left" else right_open
        other_open = right_open if self._followed == "left" else left_open
        toward_followed = State.TURN_LEFT if self._followed == "left" else State.TURN_RIGHT
        away = State.TURN_RIGHT if self._followed == "left" else State.TURN_LEFT
        # Keeping a hand on the wall: the open way nearest the followed side, at any angle.
        hand_on_wall = self._abeam(r, self._followed) <= c.wall_lost_distance
        direction = self._open_direction(self._followed == "right", hand_on_wall)
        if self._tracking and direction is not None:
            self._turn_towards(direction)
        elif followed_open and (self._tracking or not other_open):
            self._start_turn(toward_followed)
        elif other_open:
            self._start_turn(away)
        elif direction is not None:  # searching, both sides closed yet a way out at an angle
            self._turn_towards(direction)
        else:
            if symmetric:
                left = self._rng.random() < 0.5
            else:
                left = r.left > r.right  # the wide windows: where the walls are nearest
            self._start_turn(State.TURN_AROUND, 1.0 if left else -1.0)

    def _open_direction(self, prefer_clockwise: bool, hand_on_wall: bool = False) -> float | None:
        """Where to turn in the open run of candidate directions nearest the followed side, or None.

        A direction is open when the footprint, turned to it in place, could drive
        open_travel_distance along it (SectorReader.free_travel): bends of any angle show
        up as an open run at their angle, and only a dead end has none. With the hand on
        the wall (the followed wall abeam), directions behind the abeam on that side lead
        round the hand, back where the robot came from (just past a corner it turned round),
        and do not count.
        """
        # Swept about the walls' direction, not the heading: a robot skewed towards the followed
        # wall would otherwise count the way it came as an opening on that side.
        candidates = self._candidates + self._skew
        is_open = self._reader.free_travel(candidates, NOISE_ALLOWANCE) >= self.config.open_travel_distance
        if hand_on_wall:
            behind = -0.5 * math.pi - BEHIND_HAND if prefer_clockwise else 0.5 * math.pi + BEHIND_HAND
            is_open &= candidates >= behind if prefer_clockwise else candidates <= behind
        if not is_open.any():
            return None
        edges = np.flatnonzero(np.diff(np.concatenate([[0], is_open.astype(int), [0]])))
        runs = list(zip(edges[0::2], edges[1::2] - 1, strict=True))  # first and last index of each open run
        if not prefer_clockwise:
            runs = runs[::-1]
        # A run reaching the end of the sweep on the followed side is not bounded by the followed
        # wall there: it is the way back round it (the robot came from there). Any run the wall
        # bounds comes first.
        limit = 0 if prefer_clockwise else len(candidates) - 1
        if len(runs) > 1 and limit in runs[0]:
            runs = runs[1:]
        first, last = sorted(runs[0])
        # Aim OPEN_AIM past the run's edge on the followed side (or at its middle if narrower):
        # a side corridor that merges with the way ahead still gets a square turn into it.
        aim = min(OPEN_AIM, 0.5 * (candidates[last] - candidates[first]))
        return float(candidates[first] + aim if prefer_clockwise else candidates[last] - aim)

    def _turn_into_opening(self) -> None:
        """The followed wall ended: turn towards its side, by the angle of the opening there."""
        right = self._followed == "right"
        direction = self._open_direction(prefer_clockwise=right)
        if direction is None or (direction > 0.0 if right else direction < 0.0):
            self._start_turn(State.TURN_RIGHT if right else State.TURN_LEFT)
        else:
            self._turn_towards(direction)

    def _turn_towards(self, direction: float) -> None:
        """Turn in place to face ``direction`` (rad); near +-90 deg square to the walls instead.

        Square means 90 deg corrected by the skew; when that correction takes the turn more
        than SQUARE_SNAP away from the measured direction (a bend that is not square, a skew
        fitted across the bend), the measured direction wins.
        """
        state = State.TURN_LEFT if direction > 0.0 else State.TURN_RIGHT
        sign = 1.0 if direction > 0.0 else -1.0
        square = 0.5 * math.pi + sign * self._skew
        if abs(abs(direction) - 0.5 * math.pi) <= SQUARE_SNAP and abs(square - abs(direction)) <= SQUARE_SNAP:
            self._start_turn(state)
        else:
            self._start_turn(state, angle=abs(direction))

    def _start_turn(self, state: State, sign: float = 0.0, angle: float | None = None) -> None:
        """Turn in place by the nominal angle, corrected so that it ends square to the walls.

        With an explicit ``angle`` (a bend's open direction, measured on this scan) no correction.
        """
        self._enter(state)
        if state != State.TURN_AROUND:
            sign = 1.0 if state == State.TURN_LEFT else -1.0
        self._turn_sign = sign
        self._square_turn = angle is None
        if angle is not None:
            self._turn_angle = angle
            self._skew_filter.forget()  # the walls alongside after a turn of another angle are other walls
        else:
            nominal = math.pi if state == State.TURN_AROUND else 0.5 * math.pi
            self._turn_angle = nominal + sign * self._skew
            # A square turn: the walls alongside after it are square to these, and the estimate is
            # carried through it by odometry (SkewFilter.move, square at its end). Without it a robot
            # leaving a turn where no wall runs alongside (a hairpin round the end of a thin wall, a
            # junction of several corridors) drove on at whatever heading the turn and the avoidance
            # turns after it left, 15 deg off, and misread where the wall it turned round ended.
        self._wall_line = math.inf
        self._side_edge = -math.inf
        self._skew, self._skew_seen = 0.0, False

    def _enter(self, state: State) -> None:
        self._state = state
        self._search_aimed = False
        self._turn_needs_room = True
        self._state_time = 0.0
        self._traveled = 0.0
        self._turned = 0.0
        if state == State.FOLLOW:
            self._last_error = None

    def _draw_side(self) -> str:
        return "left" if self._rng.random() < 0.5 else "right"

    # -- helpers ---------------------------------------------------------------------------

    def _wall_distance(self, r: Readings) -> float:
        """The fitted line's distance when the followed wall is straight, else the side window's minimum."""
        fit = self._fit(r, self._followed)
        if fit is not None:
            return fit.distance
        return r.left if self._followed == "left" else r.right

    def _fit(self, r: Readings, side: str, direction: bool = False) -> LineFit | None:
        """The side's fitted line if it is a straight wall within reach and near parallel; ``direction``:
        the one fitted over the wider direction window."""
        c = self.config
        if direction:
            fit = r.left_direction_fit if side == "left" else r.right_direction_fit
        else:
            fit = r.left_fit if side == "left" else r.right_fit
        if (
            fit is None
            or fit.rms > c.line_fit_tolerance
            or fit.distance > c.wall_lost_distance
            or abs(fit.angle) > math.radians(c.max_skew_deg)
        ):
            return None
        return fit

    def _update_skew(self, r: Readings) -> None:
        """The heading error against the walls (SkewFilter), from the followed side's fit and the other
        side's where it agrees (a corridor), else from the other side's alone.

        Not while turning in place: the walls then sweep through the side windows, and a fit of
        a wall the robot is turning away from, carried through the rest of the turn by odometry,
        left a skew of -70 deg at the turn's end (noise-free) that rotated the next turn's
        candidate directions. An estimate that has grown past max_skew_deg is dropped likewise once a
        wall is fitted on the scan (the walls then contradict it); on a scan without one it is kept: the
        odometry carried it there (a turn that ran on past square, SkewFilter.square), and dropping it
        left the next square turn that far off square.
        """
        if self._state in TURNING:  # carried through the turn, not used until it ends
            self._skew, self._skew_seen = 0.0, False
            return
        followed = self._fit(r, self._followed, direction=True)
        other = self._fit(r, "right" if self._followed == "left" else "left", direction=True)
        if followed is not None:
            self._skew_filter.measure(followed)
        if other is not None:
            self._skew_filter.measure(other, tentative=followed is not None)
        skew = self._skew_filter.skew
        fitted = (followed or other) is not None
        if skew is not None and abs(skew) > math.radians(self.config.max_skew_deg) and fitted:
            self._skew_filter.forget()
            skew = None
        self._skew_seen = skew is not None and fitted
        self._skew = 0.0 if skew is None else skew

    def _sides_square(self, r: Readings) -> tuple[float, float]:
        """(left, right) readings square to the walls rather than to the heading.

        A robot skewed by 20 deg in a corridor sees, abeam, the corridor's walls at a slant
        instead of a side opening; looking along the walls' normal (the fitted skew) it does not.
        """
        if not self._skew_seen or self._skew == 0.0:
            return r.left_abeam, r.right_abeam
        half = math.radians(self.config.abeam_window_deg)
        return (
            self._reader.min_around(0.5 * math.pi + self._skew, half),
            self._reader.min_around(-0.5 * math.pi + self._skew, half),
        )

    @staticmethod
    def _abeam(r: Readings, side: str) -> float:
        return r.left_abeam if side == "left" else r.right_abeam

    def _windows_covered(self, r: Readings) -> bool:
        """False for a scan too coarse to put a beam in the front or the followed side's window."""
        front, left, right = r.window_beams
        return front > 0 and (left if self._followed == "left" else right) > 0

    def _record(self, r: Readings) -> None:
        self._measurements = Measurements(
            front=r.front,
            left=r.left,
            right=r.right,
            wall_distance=self._wall_distance(r),
            followed_wall=self._followed,
            clearance=r.clearance,
        )

    def _stop(self, issues: list[Issue]) -> Command:
        self._last_error = None
        self._command = (0.0, 0.0)
        return Command(0.0, 0.0, tuple(issues))

    def _emit(self, v: float, w: float, issues: list[Issue]) -> Command:
        """The command within the configured speeds; a NaN can never leave this class."""
        if not (math.isfinite(v) and math.isfinite(w)):
            return self._stop(issues)
        v = min(max(v, 0.0), self._max_v)
        w = min(max(w, -self._max_w), self._max_w)
        self._command = (v, w)
        return Command(v, w, tuple(issues))


def _half_turn(angle: float) -> float:
    """A line direction difference (rad) wrapped to [-pi/2, pi/2]: lines are the same after half a turn."""
    return math.remainder(angle, math.pi)


def _as_float(value: Any) -> float:
    """A float, or NaN for anything that is not a real number."""
    if isinstance(value, bool):
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan
