"""Monte Carlo localization on an occupancy grid: global localization, tracking and recovery, one model.

Each call to update(odometry, scan=..., beacons=..., stamp=...) does, in this order:

1. motion: once odometry has moved update_min_d / update_min_a since the last filter update, every
   particle samples the accumulated increment (motion_model.py) and every place hypothesis moves by it;
   a particle or hypothesis whose end pose is not in free space has probability 0 (the map prior).
   Odometry moving faster than max_odometry_speed is a reset of odometry, not motion;
2. measurement: log w_i += g sum_k w_k log p(z_k | x_i), the likelihood field (or beam model) mixture
   with its hit and random terms, each beam weighted by how many others share its stretch of wall and the
   scan by how far the robot moved since the last one (beam_correlation.py); beacon ranges count fully;
3. resampling, when N_eff < resample_threshold N: systematic, to max_particles while the belief holds
   several places and to what KLD-sampling asks for once one place holds it, a share drawn at random over
   free space when the likelihood collapsed (augmented MCL, recovery_alpha_slow / _fast);
4. place hypotheses (hypotheses.py): born from the particles' clusters and from the place search
   (amr_maps.scan_matcher: a budgeted branch-and-bound correlative search of the whole map), scored by the
   same measurement model, their posterior probabilities; the particles are made to agree with them (a
   likely place without particles gets a cloud);
5. the estimate: the best hypothesis's particles' weighted mean and covariance; its confidence is the best
   hypothesis's probability times the share of the belief the hypotheses hold times augmented MCL's
   w_fast / w_slow (at most 1); localized is declared at localized_probability and withdrawn under
   release_probability.

Between filter updates the estimate follows odometry, so every call returns a finite pose.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field
from typing import NamedTuple, Sequence

import numpy as np

from amr_localization.augmented_mcl import RecoveryRate
from amr_localization.beacons import BeaconReading, beacon_log_likelihood, checked_beacons, same_beacons
from amr_localization.beam_correlation import beam_weights, beams_in_view, scan_weight
from amr_localization.beam_model import BeamModel, BeamModelParams
from amr_localization.clustering import cluster_particles
from amr_localization.distance_field import DistanceField
from amr_localization.errors import BeaconError, LocalizationError, OdometryError
from amr_localization.free_space import FreeSpace
from amr_localization.hypotheses import MERGE_ANGLE, MERGE_DISTANCE, PlaceHypotheses
from amr_localization.kld_sampling import kld_sample_count, occupied_bins
from amr_localization.likelihood_field import LikelihoodField, LikelihoodFieldParams
from amr_localization.motion_model import OdometryNoise, sample_motion_model_odometry
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_localization.pose_estimate import PoseEstimate, weighted_pose
from amr_localization.resampling import effective_sample_size, systematic_resample
from amr_localization.scan_beams import Beams, select_beams
from amr_localization.sensor_mount import SensorMount
from amr_maps.occupancy_grid import OccupancyGrid
from amr_maps.scan_matcher import CorrelativeMatcher, GlobalSearch, ScoreMap
from amr_util.geometry import compose, relative_pose, wrap_angle
from amr_util.scan import ScanData

KLD_BIN_SIZE = 0.1
"""m, x and y side of a KLD histogram bin (AMCL's 0.5 m is for 10 cm maps; the maze worlds are 2 cm)."""
KLD_BIN_ANGLE = math.radians(10.0)
"""rad, heading side of a KLD histogram bin (AMCL's)."""
CLUSTER_MIN_SIZE = 10
"""particles a cell needs to be part of a cluster (a place hypothesis's birth)."""
CLOUD_SPREAD = (0.05, 0.05, math.radians(3.0))
"""m, m, rad: std of the cloud a likely place without particles gets."""
MIN_CLOUD = 50
"""particles at least in such a cloud."""
WINDOW = 10
"""scans used (with their odometry and weights) that a new hypothesis is scored on against the strongest."""
SEARCH_PROPOSALS = 4
"""best poses of one place search proposed as hypotheses."""
DEFAULT_PERIOD = 0.05
"""s between two observations when no stamps are given (the simulator's 20 Hz)."""


@dataclass
class FilterStatus:
    """What ~/status reports after each update."""

    particles: int = 0
    clusters: int = 0
    """place hypotheses followed."""
    effective_sample_size: float = 0.0
    confidence: float = 0.0
    """the best place's probability, discounted by the belief outside every place (0..1)."""
    runner_up: float = 0.0
    """the second best place's probability."""
    beams: float = 0.0
    """independent beams the last scan counted as (beam_correlation.beams_in_view) ..."""
    scan_weight: float = 0.0
    """... and the share of it that counted (the scan correlation)."""
    injected: int = 0
    killed: int = 0
    updated: bool = False
    """whether this call ran a filter update (False: odometry had not moved enough, or no data)."""
    update_time: float = 0.0
    """s of CPU for this call."""
    event: str = ""
    """the last notable event (global re-initialization, skipped scan and why, odometry reset)."""


@dataclass(frozen=True)
class Estimate:
    pose: PoseEstimate
    localized: bool
    status: FilterStatus = field(default_factory=FilterStatus)

    @property
    def confidence(self) -> float:
        return self.status.confidence


class _Seen(NamedTuple):
    """A scan used, for scoring hypotheses born later: the odometry then, its beams, their weights, its gain."""

    odometry: tuple[float, float, float]
    beams: Beams
    weights: np.ndarray
    gain: float


class ParticleFilter:
    """MCL over one map. Not thread-safe: one caller at a time."""

    def __init__(
        self,
        grid: OccupancyGrid,
        config: ParticleFilterConfig | None = None,
        range_max: float = 3.5,
        beacons: Sequence[Sequence[float]] | None = None,
    ) -> None:
        self.config = config = config or ParticleFilterConfig()
        self.field = DistanceField(grid)
        self.free_space = FreeSpace(self.field, config.free_space_clearance)
        self.mount = SensorMount(config.lidar_x, config.lidar_y, config.lidar_yaw)
        self.noise = OdometryNoise(config.alpha1, config.alpha2, config.alpha3, config.alpha4)
        if config.laser_model_type == "beam":
            self._laser = BeamModel(self.field, BeamModelParams(sigma_hit=config.sigma_hit), self.mount)
        else:
            params = LikelihoodFieldParams(config.sigma_hit, config.z_hit, config.z_rand, config.laser_likelihood_max_dist)
            self._laser = LikelihoodField(self.field, params, self.mount, range_max)
        self._grid = grid
        self._matcher: CorrelativeMatcher | None = None  # built at the first place search
        self.beacons = checked_beacons(beacons) if beacons is not None else None
        self._recovery = RecoveryRate(config.recovery_alpha_slow, config.recovery_alpha_fast)
        self._fit = RecoveryRate(config.recovery_alpha_slow, config.recovery_alpha_fast)  # the best place's own
        self._rng = np.random.default_rng(config.seed)
        self._odometry: tuple[float, float, float] | None = None  # odometry at the last filter update
        self._stamp: float | None = None
        self.hypotheses = PlaceHypotheses()
        self._window: deque[_Seen] = deque(maxlen=WINDOW)
        self.reinitialize_global()

    def retune(self, config: ParticleFilterConfig) -> None:
        """Use `config` from the next update. Only what the filter reads at each update may differ
        (counts, thresholds, motion noise, ...); the fields it built models from may not."""
        changed = self.config.structural_changes(config)
        if changed:
            raise LocalizationError(f"{', '.join(changed)}: cannot change in a built filter (build a new one)")
        self.config = config
        self.noise = OdometryNoise(config.alpha1, config.alpha2, config.alpha3, config.alpha4)

    def set_beacons(self, positions: Sequence[Sequence[float]]) -> None:
        """Give a filter built without beacons their positions (a node learns them from the first reading).
        Once set they are fixed: other positions raise (build a new filter for other beacons)."""
        checked = checked_beacons(positions)
        if self.beacons is not None:
            same_beacons(self.beacons, checked)
        self.beacons = checked

    # -- initialization ------------------------------------------------------------------

    def reinitialize_global(self) -> None:
        """Forget the pose: max_particles uniform over free space (AMCL's global localization)."""
        self.particles = self.free_space.sample(self.config.max_particles, self._rng)
        self._reset_belief()

    def initialize_pose(self, x: float, y: float, theta: float, covariance: np.ndarray | None = None) -> None:
        """Particles around a given pose (RViz's 2D Pose Estimate); covariance 3x3 over x, y, theta. The pose is
        the one place hypothesis until the scans propose others."""
        if not all(map(math.isfinite, (x, y, theta))):
            raise LocalizationError(f"initial pose: must be finite, got ({x}, {y}, {theta})")
        covariance = np.diag([0.25**2, 0.25**2, (math.pi / 12) ** 2]) if covariance is None else np.asarray(covariance, float)
        if covariance.shape != (3, 3) or not np.isfinite(covariance).all():
            raise LocalizationError("initial pose: covariance must be a finite 3x3 matrix over x, y, theta")
        covariance = 0.5 * (covariance + covariance.T) + 1e-12 * np.eye(3)
        if np.linalg.eigvalsh(covariance)[0] < 0.0:
            raise LocalizationError("initial pose: covariance is not positive semi-definite")
        count = self.config.max_particles
        draws = self._rng.multivariate_normal((x, y, theta), covariance, size=4 * count, method="cholesky")
        inside = draws[self.free_space.contains(draws[:, 0], draws[:, 1])]
        if len(inside) == 0:
            raise LocalizationError(f"initial pose: ({x:.3f}, {y:.3f}) and its spread lie outside the map's free space")
        self.particles = inside[:count] if len(inside) >= count else inside[self._rng.integers(0, len(inside), count)]
        self.particles[:, 2] = wrap_angle(self.particles[:, 2])
        self._reset_belief()
        self.hypotheses.add(np.array([[x, y, float(wrap_angle(theta))]]), np.zeros(1))
        self._covered = True  # the given pose is the prior: no place elsewhere needs searching first

    def _reset_belief(self) -> None:
        self.weights = np.full(len(self.particles), 1.0 / len(self.particles))
        self._recovery.reset()
        self._fit.reset()
        self._localized = False
        self._pending_measurement = True
        self._moved = (0.0, 0.0)  # m and rad since the last scan used
        self._estimate_odometry = self._odometry
        self._search: tuple[GlobalSearch, tuple[float, float, float]] | None = None
        self.hypotheses.clear()
        self._window.clear()
        self._shares = np.zeros(0)
        self._covered = self.config.place_search_budget == 0
        """whether the hypotheses cover the map: a place search finished since the belief was spread (or a pose
        was given, or there is no place search). Until then no hypothesis's probability is a probability over
        the whole map: the confidence is 0."""
        self._outside = 1.0
        self._estimate = weighted_pose(self.particles, self.weights)
        self.status = FilterStatus(particles=len(self.particles), effective_sample_size=float(len(self.particles)))

    # -- the update ----------------------------------------------------------------------

    @property
    def localized(self) -> bool:
        return self._localized

    def update(
        self,
        odometry: tuple[float, float, float],
        scan: ScanData | None = None,
        beacons: BeaconReading | None = None,
        stamp: float | None = None,
    ) -> Estimate:
        """One observation: odometry pose (x, y, theta in the odom frame), optionally a scan and/or beacon ranges,
        and the observation's stamp (s; without one, observations are taken DEFAULT_PERIOD apart). Returns the
        estimate (map frame). Raises LocalizationError on malformed input; the filter's state is unchanged then."""
        started = time.process_time()
        odometry = tuple(float(v) for v in odometry)
        if len(odometry) != 3 or not all(map(math.isfinite, odometry)):
            raise OdometryError(f"odometry: pose must be 3 finite numbers (x, y, theta), got {odometry}")
        if stamp is not None and not math.isfinite(float(stamp)):
            raise OdometryError(f"stamp: must be a finite number of s, got {stamp!r}")
        selected = select_beams(scan, self.config.max_beams, self.config.laser_model_type == "beam") if scan is not None else None
        if beacons is not None and self.beacons is None:
            raise BeaconError("beacon ranges: this filter was built without beacon positions")
        if beacons is not None and len(beacons.ranges) != len(self.beacons):
            raise BeaconError(f"beacon ranges: expected {len(self.beacons)} values, got {len(beacons.ranges)}")
        previous = self.status
        self.status = FilterStatus(particles=len(self.particles), clusters=len(self.hypotheses),
                                   effective_sample_size=previous.effective_sample_size,
                                   confidence=previous.confidence, runner_up=previous.runner_up)
        elapsed = DEFAULT_PERIOD if stamp is None or self._stamp is None else max(float(stamp) - self._stamp, 0.0)
        if stamp is not None:
            self._stamp = float(stamp)
        if self._odometry is None:
            self._odometry = self._estimate_odometry = odometry
        else:
            self._predict(odometry, elapsed)
        if selected is not None and not selected.returned.any():
            self.status.event = "scan skipped: no valid return (NaN, inf or out of range everywhere)"
            selected = None
        if self._pending_measurement and (selected is not None or beacons is not None):
            self._measure(selected, beacons)
        self.status.update_time = time.process_time() - started
        return Estimate(self._current_pose(odometry), self._localized, self.status)

    def _predict(self, odometry: tuple[float, float, float], elapsed: float) -> None:
        increment = relative_pose(self._odometry, odometry)
        d_trans = math.hypot(increment[0], increment[1])
        d_theta = abs(float(increment[2]))
        if d_trans > self.config.max_odometry_speed * max(elapsed, DEFAULT_PERIOD):
            # a robot does not move this fast: odometry was reset or is corrupt. Re-anchor so that the pose reported
            # stays where it was: est_odom' = new (+) old^-1 (+) est_odom
            if self._estimate_odometry is not None:
                since_estimate = relative_pose(self._odometry, self._estimate_odometry)
                self._estimate_odometry = tuple(compose(np.array([odometry]), since_estimate)[0])
            self._odometry = odometry
            self.status.event = (f"odometry jumped {d_trans:.2f} m in {elapsed:.2f} s: taken as a reset, not as motion; "
                                 "the filter carries on from here")
            return
        if d_trans < self.config.update_min_d and d_theta < self.config.update_min_a:
            return
        moved = sample_motion_model_odometry(self.particles, self._odometry, odometry, self.noise, self._rng)
        alive = self.free_space.contains(moved[:, 0], moved[:, 1])
        self.particles = moved
        self.status.killed = int(np.count_nonzero(~alive & (self.weights > 0.0)))
        self.weights = np.where(alive, self.weights, 0.0)
        self.hypotheses.move(increment)
        if len(self.hypotheses):
            self.hypotheses.keep(self.free_space.contains(self.hypotheses.poses[:, 0], self.hypotheses.poses[:, 1]))
        self._moved = (self._moved[0] + d_trans, self._moved[1] + d_theta)
        self._odometry = odometry
        self._pending_measurement = True
        if not self.weights.any():
            self.reinitialize_global()
            self.status.event = "every particle moved out of free space: global localization restarted"

    def _measure(self, beams: Beams | None, beacons: BeaconReading | None) -> None:
        config = self.config
        log_likelihood = np.zeros(len(self.particles))
        used = 0.0
        seen = None
        if beams is not None:
            weights = beam_weights(beams, config.beam_correlation_length)
            gain = scan_weight(*self._moved, config.scan_correlation_distance) if self._window or len(self.hypotheses) \
                else 1.0
            seen = _Seen(self._odometry, beams, weights, gain)
            log_likelihood += gain * self._laser.log_likelihood(self.particles, beams, weights)
            used += gain * beams_in_view(weights)
            self.status.beams, self.status.scan_weight = beams_in_view(weights), gain
        if beacons is not None:
            log_likelihood += beacon_log_likelihood(self.particles, self.beacons, beacons,
                                                    config.beacon_sigma_range, config.beacon_sigma_compass)
            used += len(self.beacons) + 1
        if used <= 0.0:
            return
        alive = self.weights > 0.0
        log_weight = np.full(len(self.particles), -np.inf)
        log_weight[alive] = np.log(self.weights[alive]) + log_likelihood[alive]
        peak = log_weight.max()
        if not math.isfinite(peak):
            self.reinitialize_global()
            self.status.event = "no particle could explain the data: global localization restarted"
            return
        weights = np.exp(log_weight - peak)
        # augmented MCL: the average per-beam likelihood (a geometric mean over the counted beams, so that it neither
        # underflows nor depends on the beam count), prior-weighted over the particles
        per_beam = np.exp(np.clip(log_likelihood / used, -700.0, 700.0))
        self._recovery.update(float(self.weights[alive] @ per_beam[alive] / self.weights[alive].sum()))
        self.weights = weights / weights.sum()
        self._moved = (0.0, 0.0)
        self._pending_measurement = False
        neff = effective_sample_size(self.weights)
        self.status.effective_sample_size = neff
        if neff < config.resample_threshold * len(self.particles):
            self._resample()
        self._weigh_places(seen, beacons)
        if seen is not None:
            self._window.append(seen)
        self._estimate_odometry = self._odometry
        self.status.updated = True
        self.status.particles = len(self.particles)
        self.status.clusters = len(self.hypotheses)

    # -- places -------------------------------------------------------------------------

    def _weigh_places(self, seen: _Seen | None, beacons: BeaconReading | None) -> None:
        """Step 4: the hypotheses observe the data, new ones are born from the clusters and the place search, the
        particles are made to agree with their probabilities, and the estimate and localized follow."""
        hypotheses = self.hypotheses
        if len(hypotheses):
            observed = self._log_likelihood(hypotheses.poses, seen, beacons)
            used = (seen.gain * beams_in_view(seen.weights) if seen is not None else 0.0) + \
                (len(self.beacons) + 1 if beacons is not None else 0.0)
            if used > 0.0:  # the best place's own per-beam likelihood, against its long-term average (as augmented MCL)
                self._fit.update(math.exp(max(min(float(observed[0]) / used, 700.0), -700.0)))
            hypotheses.observe(observed)
        clusters = cluster_particles(self.particles[:, :2], self.weights, self.config.cluster_radius, CLUSTER_MIN_SIZE,
                                     self.particles[:, 2])
        candidates = [weighted_pose(self.particles[clusters.labels == label], self.weights[clusters.labels == label])
                      for label in range(clusters.count)]
        poses = np.array([[c.x, c.y, c.theta] for c in candidates]).reshape(-1, 3)
        if seen is not None:
            poses = np.vstack([poses, self._search_places(seen)])
        self._admit(poses, seen, beacons)
        self._agree()
        self._decide(seen)

    def _admit(self, poses: np.ndarray, seen: _Seen | None, beacons: BeaconReading | None) -> None:
        """Each candidate pose re-anchors the hypothesis it is (the first, heaviest, candidate wins) or is born."""
        hypotheses = self.hypotheses
        index = hypotheses.find(poses)
        anchored: set[int] = set()
        born = []
        for pose, which in zip(poses, index):
            if which >= 0:
                if which not in anchored:
                    hypotheses.reanchor(int(which), pose)
                    anchored.add(int(which))
            elif not born or not (np.hypot(*(np.array(born)[:, :2] - pose[:2]).T) <= MERGE_DISTANCE).any():
                born.append(pose)
        if not born:
            return
        born = np.array(born)
        if len(hypotheses):
            reference = hypotheses.poses[:1]
            gain = self._window_score(born, seen, beacons) - self._window_score(reference, seen, beacons)[0]
        else:
            gain = self._window_score(born, seen, beacons)
            gain = gain - gain.max()
        hypotheses.add(born, gain)

    def _agree(self) -> None:
        """The particles near each hypothesis (within MERGE_DISTANCE and MERGE_ANGLE) hold its probability's share
        of the belief the hypotheses hold; a likely place with no particle gets a cloud (sensor resetting)."""
        hypotheses = self.hypotheses
        probabilities = hypotheses.probabilities()
        owner = hypotheses.find(self.particles)
        outside = float(self.weights[owner < 0].sum())
        clouds, cloud_weights = [], []
        for index, probability in enumerate(probabilities):
            member = owner == index
            target = probability * (1.0 - outside)
            mass = float(self.weights[member].sum())
            if mass > 0.0:
                self.weights[member] *= target / mass
            elif target * len(self.particles) >= 1.0:
                count = max(MIN_CLOUD, int(round(target * len(self.particles))))
                cloud = hypotheses.poses[index] + self._rng.standard_normal((count, 3)) * CLOUD_SPREAD
                cloud[:, 2] = wrap_angle(cloud[:, 2])
                inside = self.free_space.contains(cloud[:, 0], cloud[:, 1])
                if inside.any():
                    clouds.append(cloud[inside])
                    cloud_weights.append(np.full(int(inside.sum()), target / inside.sum()))
        if clouds:
            self.particles = np.concatenate([self.particles, *clouds])
            self.weights = np.concatenate([self.weights, *cloud_weights])
            self.status.injected += sum(len(c) for c in clouds)
        total = self.weights.sum()
        self.weights = self.weights / total if total > 0.0 else np.full(len(self.weights), 1.0 / len(self.weights))
        self._shares = probabilities
        self._outside = outside

    def _decide(self, seen: _Seen | None) -> None:
        """The estimate is the best hypothesis's particles' mean; localized follows its confidence with hysteresis."""
        config = self.config
        hypotheses = self.hypotheses
        if not len(hypotheses):
            self._estimate = weighted_pose(self.particles, self.weights)
            confidence = runner_up = 0.0
        else:
            member = hypotheses.find(self.particles) == 0
            self._estimate = weighted_pose(self.particles[member], self.weights[member]) if member.any() else \
                PoseEstimate(*map(float, hypotheses.poses[0]), np.diag([MERGE_DISTANCE**2] * 2 + [MERGE_ANGLE**2]))
            if seen is not None:
                self._estimate = self._refined(self._estimate, seen)
            hypotheses.reanchor(0, np.array([self._estimate.x, self._estimate.y, self._estimate.theta]))
            elsewhere = self._fit.injection_share() if self._covered else 1.0
            confidence = float(self._shares[0]) * (1.0 - self._outside) * (1.0 - elsewhere)
            runner_up = float(self._shares[1]) * (1.0 - self._outside) * (1.0 - elsewhere) if len(self._shares) > 1 \
                else 0.0
        threshold = config.release_probability if self._localized else config.localized_probability
        self._localized = confidence >= threshold
        self.status.confidence, self.status.runner_up = confidence, runner_up

    def _log_likelihood(self, poses: np.ndarray, seen: _Seen | None, beacons: BeaconReading | None) -> np.ndarray:
        """(H,) the data's log-likelihood at each pose, weighted as the particles' is."""
        total = np.zeros(len(poses))
        if seen is not None:
            total += seen.gain * self._laser.log_likelihood(poses, seen.beams, seen.weights)
        if beacons is not None:
            total += beacon_log_likelihood(poses, self.beacons, beacons, self.config.beacon_sigma_range,
                                           self.config.beacon_sigma_compass)
        return total

    def _window_score(self, poses: np.ndarray, seen: _Seen | None, beacons: BeaconReading | None) -> np.ndarray:
        """(H,) the log-likelihood of the scans in the window and of the current data at each pose, the poses of
        the past scans reached back by odometry (a pose in a wall then scores as if it had seen nothing)."""
        total = self._log_likelihood(poses, seen, beacons)
        for past in self._window:
            back = np.atleast_2d(compose(poses, relative_pose(self._odometry, past.odometry)))
            total += past.gain * self._laser.log_likelihood(back, past.beams, past.weights)
        return total

    @property
    def matcher(self) -> CorrelativeMatcher:
        """The scan-to-map matcher of the place search and the estimate's refinement (built at first use)."""
        if self._matcher is None:
            sigma = max(self.config.sigma_hit, self._grid.resolution)
            self._matcher = CorrelativeMatcher(ScoreMap.from_occupancy(self._grid, sigma=sigma))
        return self._matcher

    def _points(self, beams: Beams) -> np.ndarray:
        """(K, 2) the returned beams' end points in the robot's frame."""
        sensor = self.mount.sensor_poses(np.zeros((1, 3)))[0]  # the LiDAR in the robot's frame
        angles = sensor[2] + beams.angles[beams.returned]
        ranges = beams.ranges[beams.returned]
        return np.column_stack([sensor[0] + ranges * np.cos(angles), sensor[1] + ranges * np.sin(angles)])

    def _refined(self, estimate: PoseEstimate, seen: _Seen) -> PoseEstimate:
        """The estimate fitted to the scan: the matcher's best pose within the estimate's spread (at most the
        merge window), below the cell; the particles' estimate where the scan fits no better there."""
        spread = min(3.0 * estimate.position_std + self._grid.resolution, MERGE_DISTANCE)
        turn = min(3.0 * estimate.heading_std + math.radians(1.0), MERGE_ANGLE)
        points = self._points(seen.beams)
        pose = np.array([estimate.x, estimate.y, estimate.theta])
        match = self.matcher.match(points, pose, spread, turn, refine=True)
        if not np.isfinite(match.pose).all() or match.score <= self.matcher.score_interpolated(points, pose):
            return estimate
        covariance = np.where(np.isfinite(match.covariance), match.covariance, estimate.covariance)
        return PoseEstimate(float(match.pose[0]), float(match.pose[1]), float(wrap_angle(match.pose[2])), covariance)

    def _search_places(self, seen: _Seen) -> np.ndarray:
        """Proposals of the place search: a branch and bound over the whole map for the scan, place_search_budget
        nodes per update, resumed over updates (a scan's search finishes on later updates; its poses are moved by
        the odometry since). Nothing when the budget is 0."""
        budget = self.config.place_search_budget
        if budget <= 0:
            return np.zeros((0, 3))
        if self._search is None:
            search = GlobalSearch(self.matcher, self._points(seen.beams), self.free_space.mask, count=SEARCH_PROPOSALS,
                                  min_separation=2.0 * MERGE_DISTANCE, min_angle_separation=2.0 * MERGE_ANGLE)
            self._search = (search, self._odometry)
        search, odometry = self._search
        matches = search.step(budget)
        if not search.done:
            return np.zeros((0, 3))
        self._search = None
        self._covered = True
        poses = np.array([match.pose for match in matches]).reshape(-1, 3)
        return np.atleast_2d(compose(poses, relative_pose(odometry, self._odometry))).reshape(-1, 3)

    def _resample(self) -> None:
        config = self.config
        count = config.max_particles
        if len(self.hypotheses) <= 1 or (len(self._shares) and self._shares[0] >= config.localized_probability):
            bins = occupied_bins(self.particles[self.weights * len(self.particles) >= 1.0], KLD_BIN_SIZE, KLD_BIN_ANGLE)
            count = min(max(kld_sample_count(bins, config.kld_epsilon, config.kld_delta), config.min_particles),
                        config.max_particles)
        injected = int(round(self._recovery.injection_share() * count))
        keep = systematic_resample(self.weights, count - injected, self._rng)
        self.particles = np.concatenate([self.particles[keep], self.free_space.sample(injected, self._rng)])
        self.weights = np.full(count, 1.0 / count)
        self.status.injected = injected
        if injected:  # the injected guesses must be judged by the next measurement, not averaged away
            self._recovery.reset()

    def _current_pose(self, odometry: tuple[float, float, float]) -> PoseEstimate:
        """The last filter estimate moved by the odometry since that update."""
        estimate = self._estimate
        if self._estimate_odometry is None:
            return estimate
        moved = relative_pose(self._estimate_odometry, odometry)
        x, y, theta = compose(np.array([[estimate.x, estimate.y, estimate.theta]]), moved)[0]
        return PoseEstimate(float(x), float(y), float(theta), estimate.covariance)
