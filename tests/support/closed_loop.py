"""The wall follower's closed loop without ROS (the simulator library and the controller, lockstep), shared by the
control tests: each period the simulator's odometry and scan go through the approximate-time synchronizer (stamped
with simulation time, as the simulator node does) and the synchronized pair through the controller, whose command
advances the simulator by dt: the node's lockstep path minus the transport."""

from __future__ import annotations

import dataclasses
import math
from collections import Counter
from pathlib import Path

import numpy as np

from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import WallFollowerConfig, read_parameter_file
from amr_maps.world import World, load_world
from amr_simulation.config import SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.scan import ScanData
from amr_util.stamps import NANOSECONDS_PER_SECOND
from amr_util.sync import ApproximateTimeSynchronizer

ROOT = Path(__file__).resolve().parents[2]
SIM_CONFIG = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
REAL_CONFIG = read_parameter_file(ROOT / "config" / "wall_follower_real.yaml")
SECONDS = 450.0  # hard_maze's goal is reached at about 365 s


@dataclasses.dataclass
class LoopResult:
    time: float
    collisions: int
    mean_speed: float
    wall_error: float
    goal: bool | None  # None: the world has no goal
    commands_with_issues: int
    states: Counter  # periods spent in each state

    def line(self, name: str) -> str:
        goal = "-" if self.goal is None else ("reached" if self.goal else "missed")
        return (
            f"{name:16s} t={self.time:6.1f} s  collisions={self.collisions}  mean speed={self.mean_speed:.3f} m/s  "
            f"|wall error|={self.wall_error:.4f} m  goal={goal}"
        )


def run_loop(world: Path | World, config: WallFollowerConfig, seconds: float = SECONDS, **simulation) -> LoopResult:
    world = world if isinstance(world, World) else load_world(world)
    sim = Simulator(world, SimulationConfig(dt=config.dt, **simulation))
    follower = WallFollower(config)
    lidar = sim.lidar
    commands = []
    errors = []
    states: Counter = Counter()

    def on_pair(odometry: tuple[float, float], scan: ScanData) -> None:
        commands.append(follower.compute(scan, *odometry, sim.time))
        states[follower.state] += 1
        if follower.state == "FOLLOW":
            errors.append(abs(follower.measurements.wall_distance - config.target_wall_distance))

    sync = ApproximateTimeSynchronizer(2, config.sync_slop, config.sync_queue_size, on_pair)
    while sim.time < seconds and not sim.goal_reached:
        stamp = round(sim.time * NANOSECONDS_PER_SECOND)
        sync.add(0, stamp, sim.odom_twist)
        scan = ScanData(sim.ranges, lidar.angle_min, lidar.angle_increment, lidar.range_min, lidar.range_max)
        sync.add(1, stamp, scan)
        assert sim.steps + 1 == len(commands), "lockstep broken: the pair of this step was not synchronized"
        sim.step(commands[-1].v, commands[-1].w)

    path = sim.trajectory[:, :2]
    distance = float(np.nansum(np.hypot(*np.diff(path, axis=0).T)))
    return LoopResult(
        time=sim.time,
        collisions=sim.collisions,
        mean_speed=distance / sim.time,
        wall_error=float(np.mean(errors)) if errors else math.nan,
        goal=sim.goal_reached if sim.goal is not None else None,
        commands_with_issues=sum(not c.ok for c in commands),
        states=states,
    )
