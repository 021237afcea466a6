"""When the simulator node's world steps, with which commands, and what it says: no ROS (the node is its shell).

`WorldControl` holds a Simulator or Fleet and every decision the node took around it: the lockstep bookkeeping
(each robot's commands held until every robot has one, the pace, pause / resume / step and the steps owed, the
observation sent again to a robot whose command has not come, the wait for a localizer's /pose), realtime's
command timeout, the stamps (a reset restarts the simulator's time, the stamps carry on), the judgement of each
step (a collision, the goal reached, the distance travelled) and of each /pose (amr_simulation.localization_check),
and the lines the node logs and answers its services with. The node turns its messages into these calls and the
`publish` callback into messages.

    control = WorldControl(sim, publish=node_publishes, logger=node.get_logger)
    control.activate(pose_wait=0.0, scan_period=0.0, resend_period=1.0)
    control.command(0, 0.2, 0.0)     # a /cmd_vel: lockstep steps once every robot has one, then publishes

`publish(robots, now, rate)` is called with the robots whose observation goes out (each a `RobotTurn`), the
simulated time of its stamps and the real-time factor; `logger()` gives an object with info, warning and error
(the node's logger: throttled lines are throttled here, per line of this module, as rclpy does per call site).
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable

from amr_simulation.fleet import Fleet
from amr_simulation.localization_check import LocalizationCheck
from amr_simulation.simulator import Simulator
from amr_util.stamps import NANOSECONDS_PER_SECOND
from amr_util.throttle import ThrottledLogger

WARNING_PERIOD = 5.0
"""s between repeats of a throttled line."""
RATE_WINDOW = 20
"""Steps over which the status real-time factor is measured."""
STOPPED = (0.0, 0.0)


class RateMeter:
    """Simulated seconds per wall-clock second over the last RATE_WINDOW steps."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._samples: deque[tuple[float, float]] = deque(maxlen=RATE_WINDOW + 1)

    def clear(self) -> None:
        self._samples.clear()

    def update(self, sim_time: float) -> float:
        self._samples.append((sim_time, self._clock()))
        (sim0, wall0), (sim1, wall1) = self._samples[0], self._samples[-1]
        return (sim1 - sim0) / (wall1 - wall0) if wall1 > wall0 else 0.0


class RobotTurn:
    """One robot's part in the stepping: its commands, its distance, what its next step waits for."""

    def __init__(self, index: int, name: str, check: LocalizationCheck | None = None) -> None:
        self.index = index
        self.name = name
        self.prefix = f"{name}/" if name else ""
        """Of its topic names in the log lines."""
        self.label = f"{name}: " if name else ""
        """Of its log lines."""
        self.held: deque[tuple[float, float]] = deque()
        """Lockstep: commands received but not stepped yet (waiting for the other robots, paused, or paced)."""
        self.command = STOPPED
        """Realtime: the command stepped at each tick (until command_timeout)."""
        self.command_stamp = 0.0
        self.distance = 0.0
        self.last_output = 0.0
        """Wall-clock time its last observation went out."""
        self.check = check
        """Its localizer's /pose judged against the truth (enable_localization), else None."""
        self.pose_due: int | None = None
        """lockstep_pose_wait: the stamp (ns) of the observation whose /pose the next step waits for."""
        self.observed: int | None = None
        """lockstep_pose_wait: the stamp (ns) of its last observation (one sent again keeps what its /pose did)."""


class WorldControl:
    """The world's stepping and its judgement, for the simulator node (see the module docstring)."""

    def __init__(
        self,
        sim: Simulator | Fleet,
        *,
        publish: Callable[[list[RobotTurn], float, float], None],
        logger: Callable[[], object],
        judge_poses: bool = False,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.sim = sim
        self.fleet: Fleet = sim if isinstance(sim, Fleet) else sim.fleet
        self.robots = [
            RobotTurn(robot.index, robot.name, LocalizationCheck() if judge_poses else None)
            for robot in self.fleet.robots
        ]
        self._publish = publish
        self._logger = logger
        self._throttled = ThrottledLogger(logger, WARNING_PERIOD, clock)
        self._clock = clock
        self.stamp_offset = 0.0
        self.meter = RateMeter(clock)
        self.active = False
        self.paused = False
        self.owed = 0
        """Steps ~/step asked for while paused, not taken yet."""
        self.paced = False
        """Lockstep: a pace timer releases the steps (pace_tick)."""
        self.pace_ready = True
        self.pose_wait = 0.0
        self.resend_period = 0.0
        self.scan_every = 1

    @property
    def lockstep(self) -> bool:
        return self.fleet.config.mode == "lockstep"

    @property
    def named(self) -> bool:
        """A world with a `robots` list (each robot named), not the one robot of a plain world."""
        return bool(self.fleet.world.robots)

    def now(self) -> float:
        """The simulated time of the stamps: the simulator's time since reset plus an offset."""
        return self.stamp_offset + self.fleet.time

    # -- the node's lifecycle -------------------------------------------------------------------------------

    def activate(self, *, resend_period: float, pose_wait: float, scan_period: float) -> None:
        """Start: no command held, running; `pose_wait` applies in lockstep only, `scan_period` in realtime only."""
        for turn in self.robots:
            turn.command, turn.command_stamp = STOPPED, self.now()
            turn.held.clear()
        self.meter.clear()
        self.paused, self.owed = False, 0
        self.resend_period = resend_period
        config = self.fleet.config
        self.scan_every = max(1, round(scan_period / config.dt)) if config.mode == "realtime" else 1
        self.pose_wait = pose_wait if self.lockstep else 0.0
        self.active = True

    def deactivate(self) -> str:
        self.active = False
        self.forget_waits()
        for turn in self.robots:
            turn.command = STOPPED
            turn.held.clear()
        return f"stopped at t = {self.fleet.time:.2f} s"

    def forget_waits(self) -> None:
        """No /pose is waited for any more (the node's timers are gone)."""
        for turn in self.robots:
            turn.pose_due = turn.observed = None

    def pace(self, pace: float) -> float | None:
        """The period of the steady timer that paces the steps (`pace_tick` lockstep, `tick` realtime), None for
        none: lockstep 0 steps each command at once; realtime dt / pace, or dt / rate for 0."""
        config = self.fleet.config
        if config.mode == "realtime":
            self.paced = False
            return config.dt / (pace or config.rate)
        if pace > 0.0:
            self.paced, self.pace_ready = True, False
            return config.dt / pace
        self.paced, self.pace_ready = False, True
        self.release()
        return None

    # -- commands and the steps they make -------------------------------------------------------------------

    def command(self, index: int, v: float, w: float) -> None:
        """A robot's /cmd_vel: lockstep holds it (a non-finite one as zero) and steps when it can; realtime keeps
        a finite one for the next ticks."""
        if not self.active:
            return
        turn = self.robots[index]
        finite = math.isfinite(v) and math.isfinite(w)
        topic = f"/{turn.prefix}cmd_vel"
        drive = self.fleet.drive
        if not finite:
            self._throttled.warning(f"refused a non-finite {topic} (v={v}, w={w})")
        elif drive.saturation_scale(v, w) < 1.0:
            sv, sw = drive.saturate(v, w)
            self._throttled.warning(
                f"{topic} (v={v:.4g}, w={w:.4g}) beyond the robot's limits: saturated to (v={sv:.4g}, w={sw:.4g})"
            )
        if self.lockstep:
            turn.held.append((v, w) if finite else STOPPED)
            self.release()
        elif finite:
            turn.command, turn.command_stamp = (v, w), self.now()

    def release(self) -> None:
        """Lockstep: step the held commands, in order, while every robot has one (and, with lockstep_pose_wait, its
        /pose for the last observation) and pausing and the pace allow."""
        while self.active and self.robots and all(turn.held for turn in self.robots) and not self.poses_due():
            if self.paused:
                if self.owed <= 0:
                    return
                self.owed -= 1
            elif not self.pace_ready:
                return
            elif self.paced:
                self.pace_ready = False  # one step per pace period
            self.advance([turn.held.popleft() for turn in self.robots])

    def poses_due(self) -> bool:
        """lockstep_pose_wait: some robot's /pose for the last observation has not come, and its wait is not over
        (a wait that is over is given up on, with a line in the log)."""
        if self.pose_wait <= 0.0:
            return False
        due = False
        now = self._clock()
        for turn in self.robots:
            if turn.pose_due is None:
                continue
            if now - turn.last_output < self.pose_wait:
                due = True
            else:
                turn.pose_due = None
                self._throttled.info(
                    f"{turn.label}no /{turn.prefix}pose for the observation of step {self.fleet.steps} "
                    f"within lockstep_pose_wait ({self.pose_wait} s): stepping without it"
                )
        return due

    def release_late(self) -> None:
        """lockstep_pose_wait: a step that waits only for a /pose that has not come goes once the wait is over."""
        if any(turn.pose_due is not None for turn in self.robots):
            self.release()

    def pace_tick(self) -> None:
        """Lockstep with a pace: the next step may go."""
        self.pace_ready = True
        self.release()

    def tick(self) -> None:
        """Realtime: one step with each robot's latest command (none for command_timeout: stopped)."""
        if self.paused:
            if self.owed <= 0:
                return
            self.owed -= 1
        timeout = self.fleet.config.command_timeout
        for turn in self.robots:
            if timeout > 0.0 and turn.command != STOPPED and self.now() - turn.command_stamp > timeout:
                turn.command = STOPPED
                self._logger().info(f"{turn.label}no /{turn.prefix}cmd_vel for {timeout} s: stopping")
        self.advance([turn.command for turn in self.robots])

    def resend_tick(self) -> None:
        """Lockstep waits for every robot's command; a robot whose command has not come may not have heard its
        observation: it goes out again (a held command was heard: that robot waits for the others, or the loop
        is paused or paced). Paused, nothing is resent (/clock stops); a step owed is taken instead, the silent
        robots at zero velocity (their drivers hold them)."""
        silent = self.unanswered() if self.active else []
        if not silent:
            return
        if not self.paused:
            if self.named:
                waiting = ", ".join(f"/{turn.prefix}cmd_vel" for turn in silent)
                self._throttled.info(f"step {self.fleet.steps} waits for {waiting}: publishing their observation again")
            else:
                self._throttled.info("no /cmd_vel since the last observation: publishing it again")
            self.observe(silent)
        elif self.owed > 0 and self.stalled(silent):
            self.owed -= 1
            self.advance_holding_the_silent()

    def unanswered(self) -> list[RobotTurn]:
        """Lockstep: the robots whose /cmd_vel has not come for their last observation in lockstep_resend_period
        (0: none ever is)."""
        if self.resend_period <= 0.0:
            return []
        now = self._clock()
        return [turn for turn in self.robots if not turn.held and now - turn.last_output > self.resend_period]

    def stalled(self, silent: list[RobotTurn]) -> bool:
        """Every robot has either a command held or none coming (silent): nothing more will arrive to step on."""
        return bool(silent) and all(turn.held or turn in silent for turn in self.robots)

    def advance_holding_the_silent(self) -> None:
        """A step owed while paused: the held commands, zero velocity for the robots without one."""
        self.advance([turn.held.popleft() if turn.held else STOPPED for turn in self.robots])

    def advance(self, commands: list[tuple[float, float]]) -> None:
        """One step of every robot, its log lines (contacts, goal) and every robot's observation."""
        fleet = self.fleet
        before = [(robot.collisions, robot.goal_reached) for robot in fleet.robots]
        fleet.step(commands)
        dt = fleet.config.dt
        for turn, robot, (collisions, reached) in zip(self.robots, fleet.robots, before, strict=True):
            vx, vy, _ = robot.twist
            turn.distance += math.hypot(vx, vy) * dt
            x, y, _ = robot.pose
            if robot.collisions > collisions:
                self._logger().warning(
                    f"{turn.label}collision {robot.collisions} at ({x:.3f}, {y:.3f}), "
                    f"t = {fleet.time:.2f} s{self.contact_detail(robot)}"
                )
            if robot.goal_reached and not reached:
                stopping = fleet.config.stop_at_goal
                if stopping:
                    turn.command = STOPPED
                self._logger().info(
                    f"{turn.label}goal reached at ({x:.3f}, {y:.3f}), t = {fleet.time:.2f} s, "
                    f"{turn.distance:.2f} m, {robot.collisions} collisions" + (": stopping" if stopping else "")
                )
        self.observe(self.robots)

    def contact_detail(self, robot) -> str:
        """For a fleet robot: what it has run into so far (walls, which robots)."""
        if not self.named:
            return ""
        others = ", ".join(f"{name} {count}" for name, count in robot.robot_collisions.items() if count)
        return f" (walls {robot.wall_collisions}" + (f", robots: {others})" if others else ")")

    # -- observations and the /pose that answers them ---------------------------------------------------------

    def observe(self, turns: list[RobotTurn]) -> None:
        """These robots' observation goes out (publish); what their next step waits for is noted first."""
        now = self.now()
        rate = self.meter.update(now)
        stamp = round(now * NANOSECONDS_PER_SECOND)
        for turn in turns:
            turn.last_output = self._clock()
            if self.pose_wait > 0.0 and turn.check is not None:
                if stamp != turn.observed:  # sent again, an observation whose /pose came is not waited for again
                    turn.pose_due = stamp  # (the localizer drops the repeated stamp: it would never come)
                turn.observed = stamp
            if turn.check is not None:
                turn.check.observed(stamp, self.fleet.robots[turn.index].pose, self.fleet.time)
        self._publish(turns, now, rate)

    def scan_due(self) -> bool:
        """Realtime with scan_period: this step's observation has a scan (lockstep: every one)."""
        return self.fleet.steps % self.scan_every == 0

    def pose(self, index: int, stamp: int, x: float, y: float, theta: float, localized: bool) -> None:
        """A localizer's /pose of robot `index` (stamp in ns): judged against the truth at its stamp; the step
        that waited for it goes."""
        turn = self.robots[index]
        answered = False
        try:
            if turn.pose_due is not None and stamp >= turn.pose_due:
                turn.pose_due, answered = None, True
            line = turn.check.estimate(stamp, x, y, theta, localized)
            if line:
                self._logger().info(turn.label + line)
        except Exception as error:  # a NaN or stale estimate: say so, keep simulating
            self._throttled.warning(f"/{turn.prefix}pose not judged: {error}")
        if answered:
            try:
                self.release()
            except Exception as error:
                self._throttled.error(f"{turn.label}step after /pose: {type(error).__name__}: {error}")

    # -- the controls: reset, set_pose, pause, resume, step ---------------------------------------------------

    def reset(self) -> str:
        """The world back to its start; the stamps go on one dt after the last one."""
        self.stamp_offset = self.now() + self.fleet.config.dt
        self.sim.reset()
        for turn in self.robots:
            turn.distance = 0.0
        return self.restarted("reset", self.robots)

    def reset_robot(self, index: int) -> str:
        """A fleet robot back to its start; the world's time and the other robots go on (its new observation is
        stamped one dt on, so stamps never repeat). Raises SimulationError when another robot stands there."""
        self.fleet.reset_robot(index)
        self.stamp_offset += self.fleet.config.dt
        self.robots[index].distance = 0.0
        return self.restarted("reset", [self.robots[index]])

    def set_pose(self, index: int, x: float, y: float, theta: float) -> str:
        """A robot teleported (SimulationError inside a wall or another robot, or not finite)."""
        if self.named:
            self.fleet.set_pose(x, y, theta, robot=index)
        else:
            self.sim.set_pose(x, y, theta)
        self.stamp_offset += self.fleet.config.dt
        return self.restarted("set_pose", [self.robots[index]])

    def restarted(self, what: str, turns: list[RobotTurn]) -> str:
        """After a reset or teleport: the robots' held commands are dropped, new first observations go out."""
        for turn in turns:
            turn.command, turn.command_stamp = STOPPED, self.now()
            turn.held.clear()
        self.owed = 0
        self.meter.clear()
        if self.active:
            self.observe(turns)
        lines = []
        for turn in turns:
            x, y, theta = self.fleet.robots[turn.index].pose
            lines.append(f"{turn.label}robot at ({x:.3f}, {y:.3f}, {theta:.3f})")
        message = f"{what}: {'; '.join(lines)}"
        self._logger().info(message)
        return message

    def pause(self) -> str:
        was = self.paused
        self.paused, self.owed = True, 0
        return f"{'already ' if was else ''}paused at t = {self.fleet.time:.2f} s (step {self.fleet.steps})"

    def resume(self) -> str:
        was = self.paused
        self.paused, self.owed = False, 0
        self.release()
        return f"{'running' if was else 'already running'} from t = {self.fleet.time:.2f} s (step {self.fleet.steps})"

    def step_once(self) -> str:
        """Exactly one step, paused after it (pausing first if running): at once when it can go, else owed."""
        note = "" if self.paused else "paused; "
        self.paused = True
        fleet = self.fleet
        steps = fleet.steps
        self.owed += 1
        if self.lockstep:
            self.release()
            if self.owed > 0 and self.stalled(self.unanswered()):  # their drivers hold them: no command comes
                self.owed -= 1
                self.advance_holding_the_silent()
        if fleet.steps > steps:
            return f"{note}stepped to t = {fleet.time:.2f} s (step {fleet.steps})"
        waiting = (
            (
                ("the next /cmd_vel" if not self.named else "every robot's next cmd_vel")
                + " (or at zero velocity if none comes)"
            )
            if self.lockstep
            else "the next tick"
        )
        return f"{note}{self.owed} step(s) owed at t = {fleet.time:.2f} s: taken on {waiting}"
