"""Localization on real robots' logs: a CARMEN log's map, its synthesized odometry, the particle filter against
the log's corrected poses, from a known start (tracking) or from none (global localization).

- map: known-pose mapping of the log's scans at their corrected poses (amr_maps.scan_mapping.map_from_scans,
  log-odds, 5 cm cells): the map a researcher would build from a log;
- odometry: synthesized from consecutive corrected poses (amr_datasets.odometry: the odometry motion model of
  Probabilistic Robotics, table 5.6, with 5 % noise, +1 % scale error and a 0.5 deg/m heading bias by default);
- the filter: the shipped configuration (config/particle_filter.yaml) with the LiDAR at the log's laser pose (the
  log's poses are the laser's) and the motion noise of the synthesized odometry's model, alpha = (2 x 5 %)^2; each
  scan one update, stamped with the log's stamp.

`run_log` returns the figures the issue asks for: travel until the first declaration, declarations more than
0.5 m or 10 deg off, the median error while localized, and the time of each update.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from amr_datasets.carmen import LOG_MOUNT, CarmenLog
from amr_datasets.odometry import OdometryNoiseModel, synthesize_odometry
from amr_localization.particle_filter import ParticleFilter
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_localization.particle_filter_parameters import config_of
from amr_maps.occupancy_grid import OccupancyGrid
from amr_maps.scan_mapping import map_from_scans
from amr_util.geometry import wrap_angle

MAP_RESOLUTION = 0.05
"""m/cell of a log's map."""
MAP_RANGE = 30.0
"""m: readings are mapped (free along the beam, occupied at the end) up to this range."""
WRONG_POSITION = 0.5
"""m: a declaration farther off than this (or WRONG_HEADING) is wrong."""
WRONG_HEADING = math.radians(10.0)


@dataclass
class LogRun:
    """One log through the filter: per scan, the travel, the error and whether localized, and the update times."""

    name: str
    mode: str
    travel: list[float] = field(default_factory=list)
    position_error: list[float] = field(default_factory=list)
    heading_error: list[float] = field(default_factory=list)
    localized: list[bool] = field(default_factory=list)
    confidence: list[float] = field(default_factory=list)
    update_time: list[float] = field(default_factory=list)
    update_cpu: list[float] = field(default_factory=list)
    """s of CPU of the calling thread per update (the filter's helper threads and the place search's not counted): the
    update's own work, which the machine's load changes little, beside its wall time."""
    finite: bool = True

    @property
    def declared_after(self) -> float | None:
        """m of travel at the first declaration (None: never)."""
        return next((t for t, on in zip(self.travel, self.localized, strict=True) if on), None)

    @property
    def wrong(self) -> int:
        """scans localized more than WRONG_POSITION or WRONG_HEADING off."""
        return sum(
            1
            for e, h, on in zip(self.position_error, self.heading_error, self.localized, strict=True)
            if on and (e > WRONG_POSITION or h > WRONG_HEADING)
        )

    def median_error(self) -> tuple[float, float]:
        """(m, deg) median error while localized (nan when never)."""
        on = np.array(self.localized, bool)
        if not on.any():
            return math.nan, math.nan
        return (
            float(np.median(np.array(self.position_error)[on])),
            math.degrees(float(np.median(np.array(self.heading_error)[on]))),
        )

    def summary(self) -> str:
        ms = np.array(self.update_time) * 1e3
        cpu = np.array(self.update_cpu) * 1e3
        position, heading = self.median_error()
        declared = "never" if self.declared_after is None else f"{self.declared_after:.1f} m"
        return (
            f"{self.name:8s} {self.mode:8s} declared after {declared:>7s}, localized {sum(self.localized)}/"
            f"{len(self.localized)}, wrong {self.wrong}, median error {position * 100:.1f} cm {heading:.2f} deg, "
            f"update p50 {np.median(ms):.0f} ms p95 {np.percentile(ms, 95):.0f} ms max {ms.max():.0f} ms"
            + (f" (its thread's CPU p95 {np.percentile(cpu, 95):.0f} ms)" if len(cpu) else "")
            + ("" if self.finite else ", NON-FINITE estimate")
        )


def range_max(log: CarmenLog) -> float:
    """m, the log's LiDAR range (the scans' range_max)."""
    return float(log.scans[0].scan.range_max)


def log_map(log: CarmenLog, resolution: float = MAP_RESOLUTION) -> OccupancyGrid:
    """The log's map: its scans at their corrected poses (known-pose log-odds mapping)."""
    return map_from_scans(
        log.poses(), [item.scan for item in log.scans], resolution=resolution, max_range=min(MAP_RANGE, range_max(log))
    )


def log_map_beside(
    log: CarmenLog, other: CarmenLog, gap: float = 20.0, resolution: float = MAP_RESOLUTION
) -> OccupancyGrid:
    """The log's map with `other`'s building beside it: both logs' scans mapped at their corrected poses, `other`'s
    moved east so that its scans' reach (MAP_RANGE) starts `gap` m beyond the log's own and their middles are level.
    Global localization on it must tell two buildings' look-alikes apart on a map twice one building's size (the held
    back logs may be larger than the given ones). The log's poses, its odometry and its reference are unchanged."""
    if not math.isfinite(gap) or gap < 0.0:
        raise ValueError(f"gap: must be a finite number of m >= 0, got {gap!r}")
    own, beside = log.poses(), other.poses()
    shift = np.array(
        [
            own[:, 0].max() - beside[:, 0].min() + 2.0 * MAP_RANGE + gap,
            own[:, 1].mean() - beside[:, 1].mean(),
            0.0,
        ]
    )
    return map_from_scans(
        np.vstack([own, beside + shift]),
        [item.scan for item in log.scans] + [item.scan for item in other.scans],
        resolution=resolution,
        max_range=min(MAP_RANGE, range_max(log), range_max(other)),
    )


def log_parameters(log: CarmenLog, parameters: dict, seed: int, noise: OdometryNoiseModel) -> dict:
    """The filter's parameter values for a log, the same for the library run and the node: the given values, the
    LiDAR at the log's pose, the motion noise of the synthesized odometry (its alphas are standard deviations;
    AMCL's are variances: twice the std, squared)."""
    alphas = {f"alpha{k}": (2.0 * getattr(noise, f"alpha{k}")) ** 2 for k in range(1, 5)}
    values = {**parameters, **alphas, **LOG_MOUNT, "seed": seed}
    if not log.has_stamps:  # stamps made up 1 s apart: no speed to judge an odometry reset by
        values["max_odometry_speed"] = next(
            spec.maximum for spec in ParticleFilterConfig.parameter_specs() if spec.name == "max_odometry_speed"
        )
    return values


def filter_for(
    log: CarmenLog, grid: OccupancyGrid, parameters: dict, seed: int, noise: OdometryNoiseModel
) -> ParticleFilter:
    """The particle filter for a log (log_parameters)."""
    return ParticleFilter(grid, config_of(log_parameters(log, parameters, seed, noise)), range_max=range_max(log))


def run_log(
    log: CarmenLog,
    name: str,
    parameters: dict,
    mode: str = "global",
    seed: int = 0,
    grid: OccupancyGrid | None = None,
    noise: OdometryNoiseModel | None = None,
) -> LogRun:
    """The log through the filter, `mode` "tracking" (particles around the first corrected pose) or "global"."""
    if mode not in ("tracking", "global"):
        raise ValueError(f"mode: 'tracking' or 'global', got {mode!r}")
    noise = noise or OdometryNoiseModel()
    grid = grid if grid is not None else log_map(log)
    poses = log.poses()
    odometry = synthesize_odometry(poses, noise, seed)
    pf = filter_for(log, grid, parameters, seed, noise)
    if mode == "tracking":
        pf.initialize_pose(*poses[0], np.diag([0.1**2, 0.1**2, math.radians(5.0) ** 2]))
    run = LogRun(name, mode)
    travel = 0.0
    for index, (item, odom) in enumerate(zip(log.scans, odometry, strict=True)):
        if index:
            travel += float(np.hypot(*(poses[index, :2] - poses[index - 1, :2])))
        started, cpu = time.perf_counter(), time.thread_time()
        estimate = pf.update(tuple(odom), item.scan, stamp=item.stamp)
        run.update_time.append(time.perf_counter() - started)
        run.update_cpu.append(time.thread_time() - cpu)
        pose = estimate.pose
        run.finite &= all(map(math.isfinite, (pose.x, pose.y, pose.theta)))
        run.travel.append(travel)
        run.position_error.append(math.hypot(pose.x - poses[index, 0], pose.y - poses[index, 1]))
        run.heading_error.append(abs(float(wrap_angle(pose.theta - poses[index, 2]))))
        run.localized.append(bool(estimate.localized))
        run.confidence.append(estimate.status.confidence)
    return run
