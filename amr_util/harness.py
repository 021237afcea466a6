"""One stepping harness for the lockstep loops without ROS: observe, step each robot's parts, apply the commands.

Every library loop (an episode's controller, a bench's closed loop, the Gymnasium environment) runs a simulation
and its controllers in lockstep, as the nodes run in a lockstep stack: at each period every robot's observation
goes to its parts in order (a localizer, a controller, a recorder, ...), and the commands they chose advance the
simulation by one period. `Harness` is that loop, written once; the loops differ only in their parts.

The simulation is anything with the `Simulation` protocol, what the nodes see of it and nothing more:

- ``clock``: simulated seconds, as ``/clock`` and the stamps carry them;
- ``observe()``: each robot's `Observation`: the scan, the odometry pose (what ``/odometry`` and the
  ``odom -> base_link`` transform carry) and twist, and the stamp;
- ``step(commands)``: one period, a ``(v, w)`` per robot, in the order of ``observe()``.

`OneRobot` and `Robots` make one out of amr_simulation's Simulator and Fleet, or anything with their attributes
(``ranges``, ``lidar``, ``time``, ``odom_pose``, ``odom_twist``, ``step``), the scan copied as amr_util.scan.scan_of
reads it: this package imports no simulator. Over amr_evaluation.episode.AsSent(simulator) the scan and the stamp
are what the simulator node's messages carry (float32 ranges and geometry, whole nanoseconds). The ground truth a
loop grades with (the true pose, contacts, the goal region) is not part of an observation: parts that record read
it from the simulator they were built with.

A part is any callable taking a `Frame` (one robot's share of the step): it reads the observation and what the
parts before it wrote (``estimate``), writes its own (``command``), or ends the run before the commands are
applied (``stop``, the reason). ``Harness.run(seconds, stop)`` steps until a part stops, ``stop()`` (checked
before each observation: the goal region, collisions) gives a reason, or the clock reaches ``seconds``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol

from amr_util.scan import ScanData, scan_from, scan_of

Command = tuple[float, float]
"""(v, w): m/s and rad/s, a /cmd_vel's linear.x and angular.z."""


@dataclass(frozen=True)
class Observation:
    """What a robot's nodes see at one period."""

    stamp: float
    """s, the messages' stamp (the simulation's clock)."""
    scan: ScanData
    """the LiDAR scan (as its LaserScan carries it when the simulation reads it so: AsSent)."""
    odometry: tuple[float, float, float]
    """the odometry pose (x, y, theta) in the odom frame: /odometry's pose, the odom -> base_link transform."""
    twist: tuple[float, float]
    """the odometry twist (v, w): /odometry's twist."""

    def with_odometry(self, odometry: tuple[float, float, float]) -> Observation:
        return replace(self, odometry=odometry)


class Simulation(Protocol):
    """What a lockstep loop needs of a simulation (see the module docstring)."""

    @property
    def clock(self) -> float: ...

    def observe(self) -> Sequence[Observation]: ...

    def step(self, commands: Sequence[Command]) -> None: ...


class OneRobot:
    """The `Simulation` of a one-robot simulator (amr_simulation's Simulator, or anything with its ``ranges``,
    ``lidar``, ``time``, ``odom_pose``, ``odom_twist`` and ``step(v, w)``)."""

    def __init__(self, sim) -> None:
        self.sim = sim

    @property
    def clock(self) -> float:
        return self.sim.time

    def observe(self) -> tuple[Observation]:
        sim = self.sim
        return (Observation(sim.time, scan_of(sim), tuple(sim.odom_pose), tuple(sim.odom_twist)),)

    def step(self, commands: Sequence[Command]) -> None:
        ((v, w),) = commands
        self.sim.step(v, w)


class Robots:
    """The `Simulation` of several robots in one world (amr_simulation's Fleet: ``robots``, each with ``ranges``,
    ``odom_pose``, ``odom_twist``; the fleet's ``lidar``, ``time`` and ``step(commands)``), in the fleet's order."""

    def __init__(self, fleet) -> None:
        self.fleet = fleet

    @property
    def clock(self) -> float:
        return self.fleet.time

    def observe(self) -> list[Observation]:
        fleet = self.fleet
        lidar, time = fleet.lidar, fleet.time
        return [
            Observation(time, scan_from(r.ranges, lidar), tuple(r.odom_pose), tuple(r.odom_twist)) for r in fleet.robots
        ]

    def step(self, commands: Sequence[Command]) -> None:
        self.fleet.step(list(commands))


@dataclass
class Frame:
    """One robot's share of one step: its observation, what its parts made of it."""

    robot: int
    """its index in the simulation's observe()."""
    observation: Observation
    """what its nodes see; a part may replace it for the parts after it (a kidnapped robot's odometry)."""
    estimate: Any = None
    """a localizer part's answer (amr_localization's Estimate)."""
    command: Command | None = None
    """the command the robot is stepped with."""
    stop: str | None = None
    """set by a part: the run ends, this step's commands not applied; the reason."""


Part = Callable[[Frame], None]


class Harness:
    """A simulation and each robot's parts in lockstep (see the module docstring).

    parts: one sequence of parts per robot of ``simulation.observe()``; before: callables run before each
    observation (what happens to the world between two periods: a kidnapping)."""

    def __init__(
        self,
        simulation: Simulation,
        parts: Sequence[Sequence[Part]],
        before: Sequence[Callable[[], None]] = (),
    ) -> None:
        self.simulation = simulation
        self.parts = [list(robot) for robot in parts]
        self.before = list(before)
        self.steps = 0
        """periods stepped."""
        self.frames: list[Frame] = []
        """the last step's frames."""

    def step(self) -> str | None:
        """One period: observe, each robot's parts in order (robot by robot), then the simulation stepped with every
        robot's command. Returns the reason a part stopped the run (the simulation not stepped), else None."""
        for action in self.before:
            action()
        observations = self.simulation.observe()
        if len(observations) != len(self.parts):
            raise ValueError(f"{len(observations)} robots observed, parts for {len(self.parts)}")
        self.frames = []
        for index, (observation, parts) in enumerate(zip(observations, self.parts, strict=True)):
            frame = Frame(index, observation)
            self.frames.append(frame)
            for part in parts:
                part(frame)
                if frame.stop is not None:
                    return frame.stop
        missing = [frame.robot for frame in self.frames if frame.command is None]
        if missing:
            raise ValueError(f"no part commanded robot {missing[0]}")
        self.simulation.step([frame.command for frame in self.frames])
        self.steps += 1
        return None

    def run(self, seconds: float, stop: Callable[[], str | None] | None = None) -> str | None:
        """Step until ``stop()`` (checked before each period) or a part gives a reason, which is returned, or the
        clock reaches ``seconds`` (None)."""
        while True:
            reason = stop() if stop is not None else None
            if reason is not None:
                return reason
            if self.simulation.clock >= seconds:
                return None
            reason = self.step()
            if reason is not None:
                return reason


def localize(localizer) -> Part:
    """A part: the localizer (``update(odometry, scan) -> estimate``, amr_localization's ParticleFilter) given the
    frame's odometry pose and scan, its estimate in ``frame.estimate``."""

    def part(frame: Frame) -> None:
        observation = frame.observation
        frame.estimate = localizer.update(observation.odometry, observation.scan)

    return part


def drive(controller) -> Part:
    """A part: the controller that reads the scan, the odometry twist and the stamp (``compute(scan, v, w, stamp)``,
    amr_control's WallFollower) commands the robot."""

    def part(frame: Frame) -> None:
        observation = frame.observation
        command = controller.compute(observation.scan, *observation.twist, observation.stamp)
        frame.command = (command.v, command.w)

    return part


def stand(frame: Frame) -> None:
    """A part: the robot stands (a zero command)."""
    frame.command = (0.0, 0.0)
