"""A robot localizing while other robots crowd its scan, without ROS.

The other robots are not on the map: for the particle filter every beam that ends on one is an outlier.
`crowded_world` adds robots to a one-robot world: the localizing one (`ego`, at the world's start) and
`others` placed at random free points `near` it; `run_crowded` steps them together in one
`amr_simulation.fleet.Fleet` (so every LiDAR sees the others), the ego driven by the wall follower with
its particle filter fed the encoder odometry and its scan, the others standing still (`stand`) or each
following walls with its own wall follower (`drive`: they go where the ego goes, so they stay in its
scan, ahead, behind, passing): the lockstep harness (amr_util.harness) over the fleet, the ego's parts its
filter, the record and its wall follower, the others' a zero command or their wall followers. The run records,
per step, the estimate's error against the true pose, `localized`, and the share of the ego's beams that end on
another robot (its scan against the map's
ranges at the same pose, cast without the robots).

The bench is bench/bench_localization.py --crowded; tests/evaluation/test_crowded_localization.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import WallFollowerConfig
from amr_localization.particle_filter import ParticleFilter
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import World, world_from_dict
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
from amr_simulation.fleet import Fleet
from amr_util.geometry import wrap_angle
from amr_util.harness import Frame, Harness, Robots, drive, localize, stand
from amr_util.robot_description import default_robot

EGO = "ego"
"""the name of the localizing robot in a crowded world."""
ROBOT_RADIUS = default_robot().radius
PLACEMENT_CLEARANCE = 0.05
"""m of free space kept around each placed robot's footprint (from solids and from the other robots)."""
OCCLUDED_MARGIN = 0.1
"""m: a beam reading this much shorter than the map's range at the true pose ended on another robot."""
MODES = ("stand", "drive")


def crowded_world(base: dict, others: int, seed: int, near: tuple[float, float] = (0.3, 1.2)) -> dict:
    """`base` (a one-robot world dict) with a `robots` list: the ego at its start and `others` robots at random
    free points `near[0]`..`near[1]` m from it (a random heading each), clear of the solids and of each other.
    Raises ValueError if they do not fit."""
    if "robots" in base:
        raise ValueError(f"{base.get('name', 'world')}: already lists robots")
    world = world_from_dict(base)
    rng = np.random.default_rng([seed, others, 22])
    start = np.array([world.start.x, world.start.y])
    placed = [start]
    robots = [{"name": EGO, "start": [float(world.start.x), float(world.start.y), float(world.start.theta)]}]
    need = ROBOT_RADIUS + PLACEMENT_CLEARANCE
    for index in range(others):
        for _ in range(2000):
            distance = rng.uniform(*near)
            bearing = rng.uniform(-math.pi, math.pi)
            point = start + distance * np.array([math.cos(bearing), math.sin(bearing)])
            if world.clearance(point[None, :])[0] < need:
                continue
            if min(float(np.hypot(*(point - p))) for p in placed) < 2.0 * need:
                continue
            if not _in_sight(world, start, point):  # behind a wall it is not in the ego's scan
                continue
            placed.append(point)
            robots.append(
                {
                    "name": f"r{index + 1}",
                    "start": [float(point[0]), float(point[1]), float(rng.uniform(-math.pi, math.pi))],
                }
            )
            break
        else:
            raise ValueError(
                f"{base.get('name', 'world')}: no free point for robot {index + 1} of {others} within "
                f"{near[0]}-{near[1]} m of the start"
            )
    data = {key: value for key, value in base.items() if key not in ("start", "goal")}
    data["robots"] = robots
    return data


def _in_sight(world: World, origin: np.ndarray, point: np.ndarray) -> bool:
    """No solid on the segment (sampled every 5 mm: thinner than any wall)."""
    steps = max(2, int(np.hypot(*(point - origin)) / 0.005) + 1)
    samples = origin + np.linspace(0.0, 1.0, steps)[:, None] * (point - origin)
    return bool((world.clearance(samples) > 0.0).all())


@dataclass
class CrowdedTrace:
    time: list[float] = field(default_factory=list)
    localized: list[bool] = field(default_factory=list)
    position_error: list[float] = field(default_factory=list)
    heading_error: list[float] = field(default_factory=list)
    occluded: list[float] = field(default_factory=list)
    """share of the ego's returned beams ending on another robot, per step."""
    robot_collisions: int = 0
    """times the ego began touching another robot."""

    def arrays(self):
        return (
            np.array(self.time),
            np.array(self.localized, dtype=bool),
            np.array(self.position_error),
            np.array(self.heading_error),
            np.array(self.occluded),
        )


@dataclass(frozen=True)
class CrowdedRun:
    """The figures of one run."""

    first_localized: float | None
    """s, first declaration (None: never)."""
    error_at_first: tuple[float, float] | None
    """(m, deg) at the first declaration."""
    false_localized: int
    """steps declared localized with the error beyond 10 cm or 10 deg."""
    max_error: tuple[float, float] | None
    """(m, deg) the largest errors while localized."""
    rms: tuple[float, float] | None
    """(m, deg) RMS while localized after the first declaration."""
    localized_share: float
    """share of the steps after the first declaration that were localized."""
    withdrawals: int
    occluded_mean: float
    occluded_max: float
    """share of the ego's beams on other robots: mean over the run, and the largest of any step."""
    tracking_within: bool
    """every localized step within 10 cm and 10 deg."""


def run_crowded(
    world_data: dict,
    filter_config: ParticleFilterConfig,
    follower_config: WallFollowerConfig,
    seconds: float,
    mode: str = "stand",
    lidar_noise: float = 0.01,
    seed: int = 0,
    known_start: bool = False,
    range_max: float = default_robot().lidar_range_max,
    resolution: float = 0.02,
) -> CrowdedTrace:
    """Run the ego's filter in a crowded world (`crowded_world`). known_start: the filter starts around the
    true pose (tracking from the first step) instead of spread over the map (global localization)."""
    from amr_maps.rasterize import rasterize_world

    if mode not in MODES:
        raise ValueError(f"mode {mode!r}: expected one of {MODES}")
    world = world_from_dict(world_data)
    fleet = Fleet(
        world,
        SimulationConfig(
            dt=follower_config.dt,
            seed=seed,
            lidar=LidarConfig(noise_std=lidar_noise),
            encoders=EncoderConfig(noise=0.01, slip=0.02),
        ),
    )
    empty = world_from_dict(
        {key: value for key, value in world_data.items() if key != "robots"}
        | {"start": world_data["robots"][0]["start"]}
    )
    caster = NumpyRayCaster(empty.faces)
    lidar = fleet.lidar
    ego = fleet.robot(EGO)
    pf = ParticleFilter(rasterize_world(empty, resolution), filter_config, range_max=range_max)
    if known_start:
        pf.initialize_pose(*ego.pose, covariance=np.diag([0.05**2, 0.05**2, math.radians(3.0) ** 2]))
    drivers = {
        robot.name: WallFollower(
            follower_config
            if mode == "stand" or robot.name == EGO
            else _random_hand(follower_config, seed, robot.index)
        )
        for robot in fleet.robots
    }
    trace = CrowdedTrace()

    def record(frame: Frame) -> None:
        """The ego's estimate against its true pose, and the share of its beams another robot ends."""
        estimate, truth = frame.estimate, ego.pose
        trace.time.append(frame.observation.stamp)
        trace.localized.append(estimate.localized)
        trace.position_error.append(math.hypot(estimate.pose.x - truth.x, estimate.pose.y - truth.y))
        trace.heading_error.append(abs(float(wrap_angle(estimate.pose.theta - truth.theta))))
        sensor = ego.sensor_pose
        expected = caster.cast(
            sensor.x, sensor.y, sensor.theta + lidar.angle_min, lidar.angle_increment, lidar.beams, lidar.range_max
        )
        ranges = frame.observation.scan.ranges
        returned = np.isfinite(ranges)
        shadowed = returned & (ranges < expected - OCCLUDED_MARGIN)
        trace.occluded.append(float(np.count_nonzero(shadowed)) / max(int(np.count_nonzero(returned)), 1))

    parts = [
        [localize(pf), record, drive(drivers[robot.name])]
        if robot.name == EGO
        else [stand if mode == "stand" else drive(drivers[robot.name])]
        for robot in fleet.robots
    ]
    Harness(Robots(fleet), parts).run(seconds)
    trace.robot_collisions = sum(fleet.robot(EGO).robot_collisions.values())
    return trace


def _random_hand(config: WallFollowerConfig, seed: int, index: int) -> WallFollowerConfig:
    from dataclasses import replace

    hand = ("right", "left")[int(np.random.default_rng([seed, index, 7]).integers(2))]
    return replace(config, preferred_wall=hand)


def figures(trace: CrowdedTrace, position_limit: float = 0.1, heading_limit: float = 10.0) -> CrowdedRun:
    """The run's figures (limits in m and deg: what counts as a false `localized`)."""
    t, localized, position, heading, occluded = trace.arrays()
    heading = np.degrees(heading)
    wrong = localized & ((position > position_limit) | (heading > heading_limit))
    index = np.flatnonzero(localized)
    if not index.size:
        return CrowdedRun(
            None, None, int(wrong.sum()), None, None, 0.0, 0, float(occluded.mean()), float(occluded.max()), True
        )
    first = int(index[0])
    after = localized[first:]
    on = localized & (t >= t[first])
    return CrowdedRun(
        first_localized=float(t[first]),
        error_at_first=(float(position[first]), float(heading[first])),
        false_localized=int(wrong.sum()),
        max_error=(float(position[on].max()), float(heading[on].max())),
        rms=(float(np.sqrt(np.mean(position[on] ** 2))), float(np.sqrt(np.mean(heading[on] ** 2)))),
        localized_share=float(after.mean()),
        withdrawals=int(np.count_nonzero(np.diff(after.astype(int)) < 0)),
        occluded_mean=float(occluded.mean()),
        occluded_max=float(occluded.max()),
        tracking_within=not bool(wrong.any()),
    )
