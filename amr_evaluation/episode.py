"""An episode: one run of one controller in one world, a pure function of its spec, returning one record.

``EpisodeSpec`` holds everything the run depends on (the controller and its parameters themselves, the
world or maze family and seed, the goal, the seed of every random stream, LiDAR and encoder noise and
slip, the duration, controller options), as JSON-able data; ``spec.key`` is a stable hash of it (sha256
of its canonical JSON), which keys its record in a results file. ``run_episode(spec)`` builds the world
and the controller from the spec alone and returns a flat record (``RECORD_FIELDS``): the same spec
gives the same record on any machine, apart from the ``TIMING_FIELDS`` (wall-clock measures).

Controllers (library level, no DDS: the simulator library and the controllers' plain classes in lockstep):

- ``wall_follower``: amr_evaluation.wall_follower_loop (goal, collisions, stalls, wall distance error);
- ``navigation``: amr_navigation.loop (explore until the particle filter says localized, plan from
  the estimate, follow, replan; the maze_navigation stack's decisions without ROS);
- ``localization``: amr_evaluation.closed_loop (the wall follower explores while the filter localizes);
- ``plan_follow``: amr_evaluation.plan_follow (plan and follow from the true pose);
- ``fleet_navigation``: amr_evaluation.fleet_navigation (every robot of the world to its goal, each with the
  navigation loop, its own particle filter and the traffic rules; options robots, localization).

``mode="ros"`` runs the same spec through the ROS nodes (amr_evaluation.ros_episode: an amr-bringup
stack in a child process with its own ROS_DOMAIN_ID) and gives the same record: the library loops take what the
stack's nodes take (``stack_map``: the stack's one map, the filter's and the planner's, with its resolution as /map
carries it; ``AsSent``: the scan as its LaserScan carries it, float32 ranges and geometry, and the time as its
stamp). The particle filter turns a difference of 1e-7 in its inputs into millimetres at its first update, and a
controller's threshold or derivative turns it into another command some steps later: the runs go their own ways.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
import traceback
from typing import Any

import numpy as np

from amr_evaluation.figures import path_figures

SCHEMA = 1
"""bumped when a record's meaning changes: part of every key, so old records are not mixed in."""
MODES = ("library", "ros")

RECORD_FIELDS = (
    "key",
    "controller",
    "config",
    "world",
    "family",
    "world_seed",
    "goal",
    "seed",
    "lidar_noise",
    "encoder_noise",
    "slip",
    "duration",
    "mode",
    "goal_reached",
    "time_to_goal",
    "time",
    "reason",
    "collisions",
    "distance",
    "mean_speed",
    "stalls",
    "wall_error_run",
    "wall_error_following",
    "time_to_localized",
    "localization_error",
    "localization_error_max",
    "localization_rms",
    "localization_losses",
    "plans",
    "planning_failures",
    "cross_track",
    "planning_time",
    "wall_time",
    "error",
    "extra",
    "spec",
)
"""every record has these keys (None where a controller has no such figure)."""
TIMING_FIELDS = ("planning_time", "wall_time")
"""wall-clock measures: the only fields that differ between two runs of one spec."""


@dataclasses.dataclass(frozen=True)
class EpisodeSpec:
    controller: str
    """wall_follower, navigation, localization or plan_follow."""
    config: str
    """the configuration's label (sim, real, default, a file's stem and hash)."""
    parameters: dict
    """node name -> {parameter: value}: the controller's whole configuration (amr_evaluation.configs)."""
    world: dict
    """a world spec (amr_evaluation.worlds)."""
    goal: Any = None
    """None (the world's), [x, y, radius], "far" or "random"."""
    seed: int = 0
    """the simulator's noise and slip streams, the particle filter's, random goals."""
    lidar_noise: float = 0.01
    encoder_noise: float = 0.0
    slip: float = 0.0
    duration: float = 600.0
    """s of simulated time at most."""
    options: dict = dataclasses.field(default_factory=dict)
    """controller options: beams, scan_period, outlier_rate, route (wall_follower: record the grid cells
    entered as extra["route"], amr_maps.maze_route); max_collisions, goal_after (navigation: the goal given at the
    first observation at or after this many s, an idle stretch before: give_goal_after; map: a map_server YAML the
    stack navigates on instead of the world's, as `maze_navigation map:=`, the simulator running the world); kidnap
    [t, x, y, theta], symmetric (the world's symmetric counterpart, a world dict: the record's extra says when the
    feature breaking the symmetry was first seen), stop_after (s after the first declaration, and the feature seen,
    the run ends) (localization); resolution (plan_follow)."""
    mode: str = "library"

    def to_dict(self) -> dict[str, Any]:
        return {"schema": SCHEMA, **dataclasses.asdict(self)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EpisodeSpec:
        fields = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in data.items() if k in fields})

    @property
    def key(self) -> str:
        """16 hex digits of the sha256 of the spec's canonical JSON: equal specs, equal keys, anywhere."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"), allow_nan=False)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def run_episode(spec: EpisodeSpec | dict) -> dict[str, Any]:
    """The record of one episode. An episode that raises gives a record with ``error`` set (the sweep goes on)."""
    if isinstance(spec, dict):
        spec = EpisodeSpec.from_dict(spec)
    began = time.perf_counter()
    record = _blank(spec)
    try:
        if spec.mode == "ros":
            from amr_evaluation.ros_episode import run_ros

            record.update(run_ros(spec))
        elif spec.mode == "library":
            runner = _CONTROLLERS.get(spec.controller)
            if runner is None:
                raise ValueError(f"controller {spec.controller!r}: unknown (known: {', '.join(_CONTROLLERS)})")
            record.update(runner(spec))
        else:
            raise ValueError(f"mode {spec.mode!r}: expected one of {MODES}")
    except Exception as error:  # one bad episode must not end a sweep of thousands: its record says why
        record["error"] = f"{type(error).__name__}: {error}"
        record["extra"] = {"traceback": traceback.format_exc(limit=6)}
    if record["mean_speed"] is None and record["distance"] is not None and record["time"]:
        record["mean_speed"] = record["distance"] / record["time"]
    record["wall_time"] = time.perf_counter() - began
    return _finite(record)


def _blank(spec: EpisodeSpec) -> dict[str, Any]:
    from amr_evaluation.worlds import world_family, world_label

    record = dict.fromkeys(RECORD_FIELDS)
    record.update(
        key=spec.key,
        controller=spec.controller,
        config=spec.config,
        world=world_label(spec.world),
        family=world_family(spec.world),
        world_seed=spec.world.get("seed"),
        goal=spec.goal,
        seed=spec.seed,
        lidar_noise=spec.lidar_noise,
        encoder_noise=spec.encoder_noise,
        slip=spec.slip,
        duration=spec.duration,
        mode=spec.mode,
        extra={},
        spec=spec.to_dict(),
    )
    return record


def _finite(value: Any) -> Any:
    """NaN and infinities to None (JSON has neither), numpy scalars to Python ones, recursively."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


# -- shared pieces ------------------------------------------------------------------------------


def simulator_for(spec: EpisodeSpec, world, dt: float = 0.05, beams: int = 240):
    from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
    from amr_simulation.simulator import Simulator

    return Simulator(
        world,
        SimulationConfig(
            dt=dt,
            seed=spec.seed,
            lidar=LidarConfig(beams=beams, noise_std=spec.lidar_noise),
            encoders=EncoderConfig(noise=spec.encoder_noise, slip=spec.slip),
        ),
    )


def as_sent(value: float) -> float:
    """`value` as a float32 message field carries it (sensor_msgs/LaserScan's ranges and angles,
    nav_msgs/MapMetaData's resolution)."""
    return float(np.float32(value))


def as_stamped(seconds: float) -> float:
    """`seconds` as a message's stamp carries them (whole nanoseconds, amr_util.stamps), read back as a node reads
    them: the controllers' time-based terms see the nodes' intervals (0.05 s, not 0.05000000000000071)."""
    from amr_util.stamps import stamp_from_seconds, stamp_nanoseconds

    return stamp_nanoseconds(stamp_from_seconds(seconds)) * 1e-9


class AsSent:
    """A simulator whose observation reads as the simulator node's messages carry it: the scan as its LaserScan
    (float32 ranges, angles and limits, read back as float64 by amr_util.messages.scan_data), the time as their
    stamp (as_stamped). A library loop then reads what the nodes read. Everything else is the simulator's own."""

    def __init__(self, sim) -> None:
        self._sim = sim

    @property
    def time(self) -> float:
        return as_stamped(self._sim.time)

    @property
    def ranges(self) -> np.ndarray:
        return np.asarray(self._sim.ranges, dtype=np.float32).astype(float)

    @property
    def lidar(self):
        from amr_util.scan import ScanData

        lidar = self._sim.lidar
        return ScanData(
            (), *(as_sent(v) for v in (lidar.angle_min, lidar.angle_increment, lidar.range_min, lidar.range_max))
        )

    def __getattr__(self, name: str):
        return getattr(self._sim, name)


def stack_map(spec: EpisodeSpec, world):
    """The one map of the spec's ROS stack, the particle filter's and the planner's: the world rasterized at its
    map_server's resolution (config/bringup), with that resolution as /map carries it (a float32); with option
    `map`, that map_server file instead (the stack's `map:=`: a map saved by maze_mapping, in the world's frame),
    while the simulator runs the world."""
    from amr_maps.occupancy_grid import OccupancyGrid

    if spec.options.get("map"):
        from amr_maps.map_io import load_map

        grid = load_map(spec.options["map"])
    else:
        from amr_bringup.stack_config import load_bringup
        from amr_evaluation.ros_episode import STACKS
        from amr_maps.rasterize import rasterize_world

        server = next(node for node in load_bringup(STACKS[spec.controller]).nodes if node.name == "map_server")
        grid = rasterize_world(world, float(server.parameters["resolution"]))
    return OccupancyGrid(grid.data, as_sent(grid.resolution), grid.origin, grid.frame_id)


def navigation_planner(spec: EpisodeSpec, world):
    """The planner of a navigation episode, on the stack's map (the planner node plans on /map)."""
    from amr_planning.planner import Planner, PlannerConfig

    config = PlannerConfig.from_params({**spec.parameters["planner"], "world": ""})
    return Planner(stack_map(spec, world), config)


def wall_follower_config(spec: EpisodeSpec):
    """The wall follower's config; a generated world's hand (its goal was placed for it) sets the followed side."""
    from amr_control.wall_follower_config import WallFollowerConfig
    from amr_evaluation.worlds import world_hand

    params = dict(spec.parameters["wall_follower"])
    hand = world_hand(spec.world)
    if hand is not None:
        params["preferred_wall"] = hand
    return WallFollowerConfig.from_params(params)


def _goal_figures(reached: bool | None, end: float) -> dict[str, Any]:
    return {"goal_reached": reached, "time_to_goal": end if reached else None}


# -- the controllers ------------------------------------------------------------------------------


def _wall_follower(spec: EpisodeSpec) -> dict[str, Any]:
    from amr_evaluation.wall_follower_loop import run
    from amr_evaluation.worlds import build_world, with_goal, world_dict
    from amr_maps.maze_route import MazeGrid

    config = wall_follower_config(spec)
    world = with_goal(build_world(spec.world), spec.goal, spec.seed)
    options = spec.options
    grid = None
    if options.get("route"):  # the cells entered, for a grid maze's route
        data = world_dict(spec.world)
        if data is None:
            raise ValueError(f"option route: world {spec.world} is not a generated or inline grid maze")
        grid = MazeGrid.from_world(data)
    result = run(
        world,
        config,
        spec.duration,
        lidar_noise=spec.lidar_noise,
        encoder_noise=spec.encoder_noise,
        slip=spec.slip,
        seed=spec.seed,
        beams=int(options.get("beams", 240)),
        scan_period=options.get("scan_period"),
        outlier_rate=float(options.get("outlier_rate", 0.0)),
        grid=grid,
    )
    reason = "goal region reached" if result.goal else f"time limit {spec.duration:g} s"
    return {
        **_goal_figures(result.goal, result.time),
        "time": result.time,
        "reason": reason,
        "collisions": result.collisions,
        "distance": result.distance,
        "mean_speed": result.mean_speed,
        "stalls": result.stalls,
        "wall_error_run": result.wall_error_run,
        "wall_error_following": result.wall_error_following,
        "extra": {
            "state_time": result.state_time,
            "commands_with_issues": result.commands_with_issues,
            "preferred_wall": config.preferred_wall,
            **({} if result.route is None else {"route": [list(cell) for cell in result.route]}),
        },
    }


class _TimedPlanner:
    """The planner with the wall-clock time of its plan() calls added up (the navigator calls plan())."""

    def __init__(self, planner) -> None:
        self._planner = planner
        self.seconds = 0.0

    def plan(self, *args, **kwargs):
        began = time.perf_counter()
        try:
            return self._planner.plan(*args, **kwargs)
        finally:
            self.seconds += time.perf_counter() - began

    def __getattr__(self, name: str):
        return getattr(self._planner, name)


def _particle_filter(spec: EpisodeSpec, world):
    """The filter on the stack's map (the node takes /map; its own map_resolution rasterizes only a world it is
    given itself)."""
    from amr_localization.particle_filter import ParticleFilter
    from amr_localization.particle_filter_parameters import config_of

    params = {**spec.parameters["particle_filter"], "seed": spec.seed}
    return ParticleFilter(stack_map(spec, world), config_of(params), range_max=params.get("laser_max_range"))


def goal_after(spec: EpisodeSpec) -> float | None:
    """The navigation option goal_after (s), checked; None without it."""
    value = spec.options.get("goal_after")
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"option goal_after: must be a number of seconds >= 0, got {value!r}")
    return float(value)


def give_goal_after(core, after: float, goal: tuple[float, float], log=lambda event: None) -> None:
    """Option goal_after: the navigator core `core` is given `goal` at its first observation stamped at or after
    `after` s, just before it decides that observation; until then it has none (localized: IDLE, nobody drives, the
    robot stands and time goes on). The library loop's core and, through ROS, the navigator node's (ros_episode, in its
    composed stack's process) are given it so: the same observation in both, where a /goal_pose would reach the node
    at whatever observation the lockstep loop had got to."""
    step = core.step
    given: list[bool] = []

    def stepped(observation):
        if not given and observation.stamp >= after - 1e-9:
            given.append(True)
            for event in core.set_goal(goal):
                log(event)
        return step(observation)

    core.step = stepped


CONFIDENCES = ("drive_confidence", "release_confidence")
"""the navigator's confidence rule (config/navigator.yaml), passed to the library loop as the node reads it."""


def _navigation(spec: EpisodeSpec) -> dict[str, Any]:
    from amr_control.path_follower import PathFollower
    from amr_control.path_follower_config import PathFollowerConfig
    from amr_control.wall_follower import WallFollower
    from amr_evaluation.worlds import build_world, with_goal
    from amr_navigation.loop import NavigationLoop, run_navigation

    world = build_world(spec.world)
    planner = _TimedPlanner(navigation_planner(spec, world))
    world = with_goal(world, spec.goal, spec.seed, planner.costmap)
    if world.goal is None:
        raise ValueError(f"{world.name}: has no goal; give one (goal: far, random or [x, y, radius])")
    wall = wall_follower_config(spec)
    after = goal_after(spec)
    navigator = NavigationLoop(
        planner,
        WallFollower(wall),
        PathFollower(PathFollowerConfig.from_params(spec.parameters["path_follower"])),
        (world.goal.x, world.goal.y) if after is None else None,
        replan_distance=float(spec.parameters["navigator"]["replan_distance"]),
        **{key: float(spec.parameters["navigator"][key]) for key in CONFIDENCES if key in spec.parameters["navigator"]},
    )
    if after is not None:
        give_goal_after(navigator.core, after, (world.goal.x, world.goal.y))
    particle_filter = _particle_filter(spec, world)
    sim = simulator_for(spec, world, dt=wall.dt)
    run = run_navigation(
        AsSent(sim),
        particle_filter,
        navigator,
        limit=spec.duration,
        max_collisions=int(spec.options.get("max_collisions", 5)),
    )
    # reached: the true pose in the goal region (run.reached checks it when the follower says REACHED)
    reached = bool(run.reached and run.goal_distance <= world.goal.radius + 1e-9)
    return {
        **_goal_figures(reached, run.time),
        "time": run.time,
        "reason": run.reason,
        "collisions": run.collisions,
        **path_figures(sim.trajectory, wall.dt),
        "time_to_localized": run.first_localized,
        "localization_error_max": run.max_localized_error if run.first_localized is not None else None,
        "localization_losses": run.localization_losses,
        "plans": run.plans,
        "planning_failures": len(run.planning_failures),
        "cross_track": run.mean_cross_track,
        "planning_time": planner.seconds,
        "extra": {
            "follower_reached": run.follower_reached,
            "goal_distance": run.goal_distance,
            "estimate_error": run.estimate_error,
            "steps": run.steps,
            "goal_xy": [world.goal.x, world.goal.y],
            "last_planning_failure": run.planning_failures[-1] if run.planning_failures else None,
            "estimated_cross_track": float(np.mean(run.estimated_cross_track)) if run.estimated_cross_track else None,
        },
    }


def _localization(spec: EpisodeSpec) -> dict[str, Any]:
    from amr_evaluation.closed_loop import run
    from amr_evaluation.worlds import build_world, with_goal

    world = with_goal(build_world(spec.world), spec.goal, spec.seed)
    follower = wall_follower_config(spec)
    sim = simulator_for(spec, world, dt=follower.dt)
    particle_filter = _particle_filter(spec, world)
    kidnap = spec.options.get("kidnap")
    watch = None
    if spec.options.get("symmetric") is not None:  # a room one feature breaks the symmetry of: watch the feature
        from amr_evaluation.feature_watch import FeatureWatch
        from amr_maps.symmetry_families import FeatureView
        from amr_maps.world import world_from_dict

        watch = FeatureWatch(FeatureView(world, world_from_dict(spec.options["symmetric"])), sim.config.lidar)
    stop_after = spec.options.get("stop_after")
    until = None
    if stop_after is not None:
        until = watch.stop_after(float(stop_after)) if watch is not None else _localized_for(float(stop_after))
    trace = run(
        AsSent(sim),
        particle_filter,
        follower,
        spec.duration,
        kidnap=(float(kidnap[0]), tuple(float(v) for v in kidnap[1:4])) if kidnap else None,
        until=until,
    )
    t, localized, position, heading = trace.arrays()
    first = trace.first_localized()
    figures: dict[str, Any] = {
        "time": sim.time,
        "reason": f"time limit {spec.duration:g} s",
        "collisions": sim.collisions,
        **path_figures(sim.trajectory, follower.dt),
    }
    extra: dict[str, Any] = {"update_time_mean": float(np.mean(trace.update_time)) if trace.update_time else None}
    if first is not None:
        after = localized & (t >= t[first])
        figures.update(
            time_to_localized=t[first],
            localization_error=position[first],
            localization_error_max=float(position[after].max()),
            localization_rms=float(np.sqrt(np.mean(position[after] ** 2))),
            localization_losses=int(np.count_nonzero(np.diff(localized[first:].astype(int)) < 0)),
        )
        extra.update(
            heading_error=math.degrees(heading[first]),
            heading_rms=math.degrees(float(np.sqrt(np.mean(heading[after] ** 2)))),
        )
    if trace.kidnapped_at is not None:
        before = t < trace.kidnapped_at
        lost = np.flatnonzero((t >= trace.kidnapped_at) & ~localized)
        again = trace.first_localized(after=t[lost[0]]) if lost.size else None
        extra.update(
            kidnapped_at=trace.kidnapped_at,
            localized_before=bool(localized[np.flatnonzero(before)[-1]]),
            withdrawn_after=float(t[lost[0]] - trace.kidnapped_at) if lost.size else None,
            regained_after=float(t[again] - trace.kidnapped_at) if again is not None else None,
            regained_error=float(position[again]) if again is not None else None,
            regained_heading_error=math.degrees(heading[again]) if again is not None else None,
        )
    if watch is not None:
        extra.update(feature_seen=watch.seen, feature_glimpsed=watch.glimpsed, turns_apart=watch.apart)
    if world.goal is not None:
        figures.update(_goal_figures(sim.goal_reached, sim.time))
    figures["extra"] = extra
    return figures


def _localized_for(seconds: float):
    """A closed_loop.run `until`: True once the filter has been localized since `seconds` ago."""
    first: list[float] = []

    def until(sim, estimate) -> bool:
        if estimate.localized and not first:
            first.append(sim.time)
        return bool(first) and sim.time >= first[0] + seconds

    return until


def _plan_follow(spec: EpisodeSpec) -> dict[str, Any]:
    from amr_control.path_follower_config import PathFollowerConfig
    from amr_evaluation.plan_follow import plan_and_follow
    from amr_evaluation.worlds import build_world, with_goal
    from amr_planning.planner import PlannerConfig

    world = with_goal(build_world(spec.world), spec.goal, spec.seed)
    if world.goal is None:
        raise ValueError(f"{world.name}: has no goal; give one (goal: far, random or [x, y, radius])")
    follower = PathFollowerConfig.from_params(spec.parameters["path_follower"])
    sim = simulator_for(spec, world, dt=follower.dt)
    resolution = float(spec.options.get("resolution", spec.parameters["planner"]["resolution"]))
    planner = PlannerConfig.from_params({**spec.parameters["planner"], "world": "", "resolution": resolution})
    run = plan_and_follow(sim, (world.goal.x, world.goal.y), follower, planner, limit=spec.duration)
    reason = "goal region reached" if run.reached else (run.message or f"time limit {spec.duration:g} s")
    return {
        **_goal_figures(run.reached, run.time),
        "time": run.time,
        "reason": reason,
        "collisions": run.collisions,
        **path_figures(sim.trajectory, follower.dt),
        "cross_track": run.cross_track,
        "plans": 1 + run.replans if run.planned else 0,
        "planning_failures": 0 if run.planned else 1,
        "planning_time": run.planning_time,
        "extra": {"planned": run.planned, "message": run.message, "resolution": resolution},
    }


def _fleet_navigation(spec: EpisodeSpec) -> dict[str, Any]:
    """Every robot of the world to its goal (amr_evaluation.fleet_navigation); options: robots (place that many
    on the world, each sent to the next one's start: with_robots), localization ('filter' or 'truth')."""
    from amr_evaluation.fleet_navigation import run_fleet
    from amr_evaluation.worlds import build_world, world_dict
    from amr_maps.world import world_from_dict
    from amr_navigation.traffic import TrafficConfig
    from amr_planning.fleet_starts import with_robots

    robots = spec.options.get("robots")
    if robots is not None:
        data = world_dict(spec.world)
        if data is None:
            import yaml

            from amr_maps.world import resolve_world_path

            data = yaml.safe_load(resolve_world_path(spec.world["file"]).read_text(encoding="utf-8"))
        world = world_from_dict(with_robots(data, int(robots), spec.seed), default_name=spec.world.get("name", "world"))
    else:
        world = build_world(spec.world)
    run = run_fleet(
        world,
        spec.parameters,
        seed=spec.seed,
        lidar_noise=spec.lidar_noise,
        encoder_noise=spec.encoder_noise,
        slip=spec.slip,
        duration=spec.duration,
        localization=spec.options.get("localization", "filter"),
        traffic=TrafficConfig.from_params(spec.parameters["traffic"]),
    )
    every = run.reached == len(run.robots)
    summary = run.as_dict()
    return {
        **_goal_figures(every, run.time),
        "time": run.time,
        "reason": run.reason,
        "collisions": run.wall_contacts + run.robot_contacts,
        "distance": sum(r.distance for r in run.robots),
        "plans": sum(r.plans for r in run.robots),
        "extra": {
            key: summary[key]
            for key in (
                "reached",
                "robots",
                "robot_contacts",
                "wall_contacts",
                "false_localized",
                "withdrawals",
                "unsure_time",
                "per_robot",
            )
        },
    }


_CONTROLLERS = {
    "wall_follower": _wall_follower,
    "navigation": _navigation,
    "localization": _localization,
    "plan_follow": _plan_follow,
    "fleet_navigation": _fleet_navigation,
}
