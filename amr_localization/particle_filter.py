"""Monte Carlo localization on an occupancy grid: global localization, tracking and recovery.

Each call to update(odometry, scan=..., beacons=...) does, in this order:

1. motion: once odometry has moved update_min_d / update_min_a since the last
   filter update, every particle samples the accumulated increment
   (motion_model.py); particles whose move leaves free space are killed;
2. measurement: weights *= p(z | x)^beta, by the likelihood field
   (default) or the beam model for a scan (its log-likelihood scaled by
   likelihood_exponent: 60 beams on one map are far from independent), by the
   beacon model for ranges, with beta <= 1 tempered so that one update cannot
   wipe out most hypotheses (tempering.py); until localized is declared, the
   places the evidence ledger follows (evidence_ledger.py: those the rival
   search finds from the first scan on and the estimate's, moved by the
   odometry, re-fitted to each scan) add the scan's log-likelihood, untempered
   and with the beams' free paths checked, to their accumulated evidence, and
   particles at a place it has ruled out die;
3. resampling, when N_eff < resample_threshold N: systematic, to
   max_particles while the particles form several clusters (the course's
   rule: every candidate place keeps thousands of particles, so that chance
   alone does not erase one of two places that look the same) and, once a
   single cluster holds the weight, to as many as KLD-sampling asks for; a
   share of them drawn at random over free space when the likelihood collapsed
   (augmented MCL);
4. clusters and estimate: the heaviest cluster's weighted mean pose and
   covariance; `localized` is declared after localized_confirmations updates
   in a row with one cluster holding localized_min_cluster_share of the weight,
   its spread under the position and heading limits and the scan fitting its
   pose (scan_fit.py), no more than see_through_max_share of the scan's beams
   reading through the map's walls there (other robots hiding the walls that
   tell a look-alike place apart: unexpected_obstacles.seen_through), and no
   other place explains the recent scans as well (the rival search) unless
   the ledger's evidence since it began following that place rules it out;
   withdrawn as soon as the cluster's share, spread or
   fit goes beyond the withdrawal margins (hysteresis, see WITHDRAW_*), or when,
   searched again every recheck_updates updates, another place explains the
   recent scans clearly better (a kidnapping into a look-alike place); when one
   cluster holds the weight but the scan keeps not fitting it for lost_updates
   updates, the robot is lost (kidnapped): global localization restarts.

Between filter updates the estimate follows odometry, so every call returns a
pose. A particle filter in a world with symmetric places keeps one cluster per
place, so it does not declare itself localized until the symmetry is broken;
where one feature seen for a few seconds per lap breaks it, the ledger keeps
what was seen (docs/localization_symmetry.md).
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field, replace
from typing import Sequence

import numpy as np

from amr_localization.augmented_mcl import RecoveryRate
from amr_localization.beacons import BeaconReading, beacon_log_likelihood, checked_beacons, same_beacons
from amr_localization.beam_model import BeamModel, BeamModelParams
from amr_localization.clustering import cluster_particles
from amr_localization.distance_field import DistanceField
from amr_localization.errors import BeaconError, LocalizationError, OdometryError
from amr_localization.evidence_ledger import EvidenceLedger, LedgerParams
from amr_localization.free_space import FreeSpace
from amr_localization.kld_sampling import kld_sample_count, occupied_bins
from amr_localization.likelihood_field import LikelihoodField, LikelihoodFieldParams
from amr_localization.motion_model import OdometryNoise, odometry_increment, sample_motion_model_odometry
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_localization.pose_estimate import PoseEstimate, weighted_pose
from amr_localization.resampling import effective_sample_size, systematic_resample
from amr_localization.rival_check import (PlaceSearch, RivalCheckParams, Snapshot, find_rivals, history_score,
                                          search_places)
from amr_localization.scan_beams import Beams, select_beams
from amr_localization.scan_fit import scan_fit
from amr_localization.sensor_mount import SensorMount
from amr_localization.tempering import tempered_exponent
from amr_localization.unexpected_obstacles import MapRanges, seen_through, unexpected, without_unexpected
from amr_maps.occupancy_grid import OccupancyGrid
from amr_util.geometry import compose, relative_pose, wrap_angle
from amr_util.scan import ScanData

WITHDRAW_SPREAD_FACTOR = 2.0
"""localized is withdrawn when the spread exceeds this many times the declaration limit ..."""
WITHDRAW_MARGIN = 0.15
"""... or the cluster's share or the fit falls this far below their declaration limits."""
LEDGER_MARGIN = 0.5
"""per-beam log-likelihood: places the rival search finds within this of the estimate enter the evidence ledger."""
LEDGER_BEAMS = 180
"""beams of each scan the evidence ledger weighs its few places on."""
LEDGER_SEED_SHARE = 0.5
"""the ledger, when it begins (it follows nothing), follows the heaviest cluster's place too if it holds this share."""
SEE_THROUGH_BEAMS = 360
"""beams of the scan the see-through check counts (every one of a 1-degree LiDAR's)."""
MAX_LOG_ODDS = 50.0
"""a rival's cloud is at most e^50 times as heavy as the estimate's cluster (numbers stay finite)."""
LEDGER_WALL_TOLERANCE = 0.1
"""m: a ledger entry is ruled out for leaving free space only this far past the particles' border (free cells
free_space_clearance minus this from a wall): its pose is fitted to the scans to a few cm, and the true place's
entry, 5.5 cm off a robot turning 0.10 m from a wall, was ruled out for good and a look-alike declared (issue 22)."""


@dataclass
class FilterStatus:
    """What ~/status reports after each update."""

    particles: int = 0
    clusters: int = 0
    effective_sample_size: float = 0.0
    cluster_share: float = 0.0
    fit: float = 0.0
    injected: int = 0
    killed: int = 0
    beta: float = 0.0
    """the tempering exponent of the last measurement update."""
    updated: bool = False
    """whether this call ran a filter update (False: odometry had not moved enough, or no data)."""
    update_time: float = 0.0
    """s of CPU for this call."""
    unexpected: int = 0
    """beams of the last scan dropped as unexpected obstacles (reading short of the map at the estimate)."""
    event: str = ""
    """the last notable event (global re-initialization, skipped scan and why)."""


@dataclass(frozen=True)
class Estimate:
    pose: PoseEstimate
    localized: bool
    status: FilterStatus = field(default_factory=FilterStatus)


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
        self._scorer = LikelihoodField(self.field, LikelihoodFieldParams(config.sigma_hit), self.mount, range_max)
        self._map_ranges = MapRanges(self.field, self.mount)
        self._coarse_scorer = LikelihoodField(self.field, LikelihoodFieldParams(config.rival_coarse_sigma), self.mount,
                                              range_max)
        self._rival_params = RivalCheckParams(margin=config.rival_margin)
        ledger_space = FreeSpace(self.field, max(0.0, config.free_space_clearance - LEDGER_WALL_TOLERANCE))
        self._ledger = EvidenceLedger(self._scorer, ledger_space,
                                      LedgerParams(threshold=config.evidence_threshold,
                                                   dead_zone=config.evidence_dead_zone))
        self._history: deque[Snapshot] = deque(maxlen=config.history_length)  # scans history_spacing apart
        self._newest: Snapshot | None = None  # ... and the newest since the last of them
        self.beacons = checked_beacons(beacons) if beacons is not None else None
        self._recovery = RecoveryRate(config.recovery_alpha_slow, config.recovery_alpha_fast)
        self._rng = np.random.default_rng(config.seed)
        self._odometry: tuple[float, float, float] | None = None  # odometry at the last filter update
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
        """Particles around a given pose (RViz's 2D Pose Estimate); covariance 3x3 over x, y, theta."""
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

    def _reset_belief(self) -> None:
        self.weights = np.full(len(self.particles), 1.0 / len(self.particles))
        self._recovery.reset()
        self._localized = False
        self._contested = False
        self._withdrawn_from: np.ndarray | None = None  # while contested: the place localized was withdrawn from
        self._confirmations = 0
        self._misfits = 0
        self._since_recheck = 0
        self._moved_since_resample = False
        self._pending_measurement = True
        self._estimate_odometry = self._odometry
        self._history.clear()
        self._newest = None
        self._ledger.clear()
        self.rivals = np.zeros((0, 3))
        self._clusters = cluster_particles(self.particles[:, :2], self.weights, self.config.cluster_radius,
                                           self.config.cluster_min_size)
        self._estimate = self._cluster_estimate()
        self.status = FilterStatus(particles=len(self.particles), clusters=self._clusters.count,
                                   effective_sample_size=float(len(self.particles)))

    # -- the update ----------------------------------------------------------------------

    @property
    def localized(self) -> bool:
        return self._localized

    def update(
        self,
        odometry: tuple[float, float, float],
        scan: ScanData | None = None,
        beacons: BeaconReading | None = None,
    ) -> Estimate:
        """One observation: odometry pose (x, y, theta in the odom frame) and optionally a scan and/or beacon
        ranges. Returns the estimate (map frame). Raises LocalizationError on malformed input; the filter's
        state is unchanged then."""
        started = time.process_time()
        odometry = tuple(float(v) for v in odometry)
        if len(odometry) != 3 or not all(map(math.isfinite, odometry)):
            raise OdometryError(f"odometry: pose must be 3 finite numbers (x, y, theta), got {odometry}")
        selected = select_beams(scan, self.config.max_beams, self.config.laser_model_type == "beam") if scan is not None else None
        if beacons is not None and self.beacons is None:
            raise BeaconError("beacon ranges: this filter was built without beacon positions")
        if beacons is not None and len(beacons.ranges) != len(self.beacons):
            raise BeaconError(f"beacon ranges: expected {len(self.beacons)} values, got {len(beacons.ranges)}")
        self.status = FilterStatus(particles=len(self.particles), clusters=self._clusters.count,
                                   effective_sample_size=self.status.effective_sample_size,
                                   cluster_share=self.status.cluster_share, fit=self.status.fit)
        if self._odometry is None:
            self._odometry = self._estimate_odometry = odometry
        else:
            self._predict(odometry)
        if selected is not None and not selected.returned.any():
            self.status.event = "scan skipped: no valid return (NaN, inf or out of range everywhere)"
        if self._pending_measurement and (selected is not None or beacons is not None):
            self._measure(selected, beacons, scan)
        self.status.update_time = time.process_time() - started
        return Estimate(self._current_pose(odometry), self._localized, self.status)

    def _predict(self, odometry: tuple[float, float, float]) -> None:
        _, d_trans, _ = odometry_increment(self._odometry, odometry)
        d_theta = abs(float(wrap_angle(odometry[2] - self._odometry[2])))
        if d_trans > self.config.max_odometry_jump:
            # a robot does not move this far between two observations: odometry was reset or is corrupt
            # re-anchor so that the pose reported stays where it was: est_odom' = new (+) old^-1 (+) est_odom
            if self._estimate_odometry is not None:
                since_estimate = relative_pose(self._odometry, self._estimate_odometry)
                self._estimate_odometry = tuple(compose(np.array([odometry]), since_estimate)[0])
            self._odometry = odometry
            self.status.event = f"odometry jumped {d_trans:.2f} m: ignored as motion, the filter carries on from here"
            return
        if d_trans < self.config.update_min_d and d_theta < self.config.update_min_a:
            return
        moved = sample_motion_model_odometry(self.particles, self._odometry, odometry, self.noise, self._rng)
        self._ledger.move(relative_pose(self._odometry, odometry))
        if self._withdrawn_from is not None:
            self._withdrawn_from = compose(self._withdrawn_from[None, :], relative_pose(self._odometry, odometry))[0]
        alive = self.free_space.segments_free(self.particles[:, :2], moved[:, :2])
        self.particles = moved
        self.status.killed = int(np.count_nonzero(~alive))
        self.weights = np.where(alive, self.weights, 0.0)
        self._odometry = odometry
        self._pending_measurement = True
        if not self.weights.any():
            self.reinitialize_global()
            self.status.event = "every particle moved into a wall: global localization restarted"

    def _measure(self, beams: Beams | None, beacons: BeaconReading | None, scan: ScanData | None = None) -> None:
        scanned = beams is not None and bool(beams.returned.any())
        if scanned:
            whole, beams = beams, self._expected(beams, count=True)
            self._remember(beams, whole)
            if len(self._ledger):  # first: it may kill particles at ruled-out places, or add clouds
                self._observe_evidence(scan, int(np.count_nonzero(beams.returned)))
        log_likelihood = np.zeros(len(self.particles))
        used = 0
        if scanned:
            # scan beams are not independent: their log-likelihood counts likelihood_exponent times
            log_likelihood += self.config.likelihood_exponent * self._laser.log_likelihood(self.particles, beams)
            used += int(np.count_nonzero(beams.returned))
        if beacons is not None:
            log_likelihood += beacon_log_likelihood(self.particles, self.beacons, beacons,
                                                    self.config.beacon_sigma_range, self.config.beacon_sigma_compass)
            used += len(self.beacons) + 1
        if used == 0:
            return
        alive = self.weights > 0.0
        log_prior = np.full(len(self.particles), -np.inf)
        log_prior[alive] = np.log(self.weights[alive])
        beta = tempered_exponent(log_prior, log_likelihood, 1.0, self.config.tempering_min_ess_ratio)
        self.status.beta = beta
        log_weight = log_prior + beta * log_likelihood
        peak = log_weight.max()
        weights = np.exp(log_weight - peak)
        total = weights.sum()
        if not (math.isfinite(peak) and total > 0.0):
            self.reinitialize_global()
            self.status.event = "no particle could explain the data: global localization restarted"
            return
        # augmented MCL: the average per-measurement likelihood (a geometric mean over the beams, so that
        # it neither underflows nor depends on the beam count), prior-weighted over the particles
        per_beam = np.exp(np.clip(log_likelihood / used, -700.0, 700.0))
        self._recovery.update(float(self.weights[alive] @ per_beam[alive] / self.weights[alive].sum()))
        self.weights = weights / total
        self._pending_measurement = False
        neff = effective_sample_size(self.weights)
        self.status.effective_sample_size = neff
        if neff < self.config.resample_threshold * len(self.particles):
            self._resample()
        self._clusters = cluster_particles(self.particles[:, :2], self.weights, self.config.cluster_radius,
                                           self.config.cluster_min_size)
        self._estimate = self._cluster_estimate()
        self._estimate_odometry = self._odometry
        self._decide_localized(beams, scan)
        self.status.updated = True
        self.status.particles = len(self.particles)
        self.status.clusters = self._clusters.count

    def _observe_evidence(self, scan: ScanData, used: int) -> None:
        """The ledger weighs its places on LEDGER_BEAMS beams (a doorway a few degrees wide falls between the
        filter's max_beams), each scan counting as much as it does for the particles."""
        beams = self._expected(select_beams(scan, LEDGER_BEAMS, keep_no_return=True))  # no return: a free path too
        short_of = None
        if self._contested and self.config.unexpected_obstacles:  # a beam short at any place it follows: no evidence
            margin = self._ledger.params.free_path_margin
            short_of = lambda poses: np.array([unexpected(self._map_ranges, pose, beams, margin) for pose in poses])
        self._ledger.observe(beams, self.config.likelihood_exponent * used / max(len(beams.ranges), 1), short_of)
        self._prune_ruled_out()

    def _prune_ruled_out(self) -> None:
        """Particles at a place the evidence ledger has ruled out die, as those that cross a wall do; if that
        leaves none (the particles all sit at ruled-out places), the places the ledger still follows get
        clouds first, as heavy as their odds."""
        ledger = self._ledger
        out = ledger.ruled_out()
        if out.all():  # every place it followed left free space: it knows nothing any more
            ledger.clear()
        if not out.any() or out.all():
            return
        doomed = np.zeros(len(self.particles), dtype=bool)
        for index in np.flatnonzero(out):
            doomed |= ledger.near(self.particles, index)
        for index in np.flatnonzero(~out):
            doomed &= ~ledger.near(self.particles, index)
        alive = self.weights > 0.0
        if not (alive & ~doomed).any():
            count = len(self.particles)
            self._adopt_rivals(ledger.poses[~out], np.exp(ledger.evidence[~out]))
            doomed = np.concatenate([doomed, np.zeros(len(self.particles) - count, dtype=bool)])
            alive = self.weights > 0.0
        self.status.killed += int(np.count_nonzero(doomed & alive))
        self.weights = np.where(doomed, 0.0, self.weights)
        self.weights /= self.weights.sum()

    def _expected(self, beams: Beams, count: bool = False) -> Beams:
        """The beams without those ending on something not on the map (another robot): reading short of the
        map's range at the estimate, once one cluster holds the weight (unexpected_obstacles.py). While contested
        (a recheck withdrew localized for a place elsewhere): short at any cluster heavy enough to stand in the way
        of a declaration, so that the places are weighed on the beams that none of them reads as ending on
        something unmapped (a beam on another robot where a look-alike place has a wall must not decide)."""
        config = self.config
        if not config.unexpected_obstacles or not self._clusters.count or \
                self._clusters.weights[0] < config.unexpected_min_cluster_share:
            return beams
        estimate = self._current_pose(self._odometry)
        poses = [np.array([estimate.x, estimate.y, estimate.theta])]
        if self._contested:
            poses += self._cluster_poses(1.0 - config.localized_min_cluster_share)[1:]
        kept, dropped = without_unexpected(self._map_ranges, np.array(poses), beams, config.unexpected_obstacle_margin,
                                           config.unexpected_obstacle_max_share)
        if count:
            self.status.unexpected = dropped
        return kept

    def _remember(self, beams: Beams, whole: Beams) -> None:
        """Keep scans history_spacing apart for the rival check, and the newest one: the beams the particles were
        weighed on (without those reading short at the estimate) and, for the recheck while localized, the whole
        scan (a robot carried to a look-alike place: the beams reading short at the old estimate are the ones that
        tell the places apart)."""
        snapshot = Snapshot(self._odometry, beams, None if whole is beams else whole)
        if self._history:
            last = self._history[-1].odometry
            moved = math.hypot(self._odometry[0] - last[0], self._odometry[1] - last[1])
            turned = abs(float(wrap_angle(self._odometry[2] - last[2])))
            if moved < self.config.history_spacing and turned < 2.0 * self.config.history_spacing:
                self._newest = snapshot
                return
        self._history.append(snapshot)
        self._newest = None

    def recent_scans(self, whole: bool = False) -> list[Snapshot]:
        """At most history_length scans: history_spacing apart over the recent path, then the newest; whole: with
        every beam of each scan, those that read short of the map at the estimate too."""
        recent = list(self._history)
        if self._newest is not None:
            full = len(self._history) == self.config.history_length
            recent = recent[1 if full else 0:] + [self._newest]
        if whole:
            recent = [Snapshot(s.odometry, s.whole) if s.whole is not None else s for s in recent]
        return recent

    def _resample(self) -> None:
        config = self.config
        count = config.max_particles
        if self._clusters.count == 1 and self._clusters.weights[0] >= config.localized_min_cluster_share:
            bins = occupied_bins(self.particles[self.weights * config.max_particles >= 1.0], config.kld_bin_size,
                                 config.kld_bin_angle)
            count = min(max(kld_sample_count(bins, config.kld_epsilon, config.kld_delta), config.min_particles),
                        config.max_particles)
        injected = int(round(self._recovery.injection_share() * count))
        keep = systematic_resample(self.weights, count - injected, self._rng)
        self.particles = np.concatenate([self.particles[keep], self.free_space.sample(injected, self._rng)])
        self.weights = np.full(count, 1.0 / count)
        self.status.injected = injected
        if injected:  # the injected guesses must be judged by the next measurement, not averaged away
            self._recovery.reset()

    def _cluster_estimate(self) -> PoseEstimate:
        clusters = self._clusters
        if clusters.count == 0:
            return weighted_pose(self.particles, self.weights)
        member = clusters.labels == 0
        return weighted_pose(self.particles[member], self.weights[member])

    def _cluster_poses(self, min_share: float) -> list[np.ndarray]:
        """The weighted mean pose (x, y, theta) of every cluster holding at least `min_share` of the weight,
        heaviest first (the particles as they are now: moved by the last motion update)."""
        clusters, poses = self._clusters, []
        for label, weight in enumerate(clusters.weights):
            member = clusters.labels == label
            if weight < min_share or not member.any() or not self.weights[member].sum() > 0.0:
                continue
            mean = weighted_pose(self.particles[member], self.weights[member])
            poses.append(np.array([mean.x, mean.y, mean.theta]))
        return poses

    def _decide_localized(self, beams: Beams | None, scan: ScanData | None) -> None:
        config = self.config
        share = float(self._clusters.weights[0]) if self._clusters.count else 0.0
        pose = np.array([self._estimate.x, self._estimate.y, self._estimate.theta])
        fit = scan_fit(self.field, self.mount, pose, beams, config.fit_distance) if beams is not None else 1.0
        self.status.cluster_share, self.status.fit = share, fit
        position_std, heading_std = self._estimate.position_std, self._estimate.heading_std
        if self._localized:
            self._localized = (
                share >= config.localized_min_cluster_share - WITHDRAW_MARGIN
                and fit >= config.localized_min_fit - WITHDRAW_MARGIN
                and position_std <= WITHDRAW_SPREAD_FACTOR * config.localized_max_position_std
                and heading_std <= WITHDRAW_SPREAD_FACTOR * config.localized_max_heading_std
            )
            self._confirmations = 0
            self._since_recheck += 1
            if self._localized and config.rival_check and config.recheck_updates and \
                    self._since_recheck >= config.recheck_updates:
                self._recheck(pose)
            return
        dominant = share >= config.localized_min_cluster_share - WITHDRAW_MARGIN
        self._misfits = self._misfits + 1 if dominant and fit < config.localized_min_fit else 0
        if config.lost_updates and self._misfits >= config.lost_updates:
            self.reinitialize_global()
            self.status.event = (f"lost: the scan has not fitted the only cluster for {config.lost_updates} updates "
                                 f"(fit {fit:.2f}): global localization restarted")
            return
        recent = self.recent_scans()
        if config.rival_check and recent and not len(self._ledger):
            # from the first scan on (and again after the ledger was cleared), follow the places that explain
            # the scans best, so that a feature seen before the first declaration attempt is not lost (a robot
            # starting beside it); the estimate's place too once the particles begin to agree on it
            self._follow(search_places(self.free_space, self._scorer, self._coarse_scorer, recent, pose,
                                       self._rival_params), with_estimate=share >= LEDGER_SEED_SHARE)
        confident = (
            share >= config.localized_min_cluster_share
            and fit >= config.localized_min_fit
            and position_std <= config.localized_max_position_std
            and heading_std <= config.localized_max_heading_std
        )
        self._confirmations = self._confirmations + 1 if confident else 0
        if self._confirmations >= config.localized_confirmations and config.rival_check and recent:
            search = search_places(self.free_space, self._scorer, self._coarse_scorer, recent, pose, self._rival_params)
            self.rivals, odds = self._weigh_rivals(search)
            self.rivals, odds = self._with_withdrawn_place(pose, self.rivals, odds)
            if len(self.rivals):
                self._adopt_rivals(self.rivals, odds)
                self._confirmations = 0
                self.status.event = (f"ambiguous: {len(self.rivals)} other place(s) explain the recent scans as well "
                                     "and the evidence so far does not rule them out")
        # last (the rival search gives the other places their particles, so it goes first): no place the scan reads
        # through the walls of
        if self._confirmations >= config.localized_confirmations and config.see_through_check and scan is not None:
            self._refuse_seen_through(pose, scan)
        self._localized = self._confirmations >= config.localized_confirmations
        if self._localized:  # the ledger has done its work: while localized the recheck watches for rivals, and
            self._ledger.clear()  # a withdrawal starts it afresh from the scans then
            self._contested, self._withdrawn_from = False, None

    def _refuse_seen_through(self, pose: np.ndarray, scan: ScanData) -> None:
        """No declaration at a place where more than see_through_max_share of the returned beams read through
        its walls (unexpected_obstacles.seen_through, within the declaration limits of the estimate): other robots
        hid what tells it from the robot's place."""
        config = self.config
        beams = select_beams(scan, SEE_THROUGH_BEAMS)
        through = int(np.count_nonzero(seen_through(
            self._map_ranges, pose, beams, config.see_through_margin,
            (config.localized_max_position_std, config.localized_max_heading_std))))
        returned = int(np.count_nonzero(beams.returned))
        if through > config.see_through_max_share * returned:
            self._confirmations = 0
            self.status.event = (f"not localized at ({pose[0]:.2f}, {pose[1]:.2f}): {through} of {returned} beams "
                                 f"read {config.see_through_margin:g} m or more beyond the map's walls there")

    def _follow(self, search: PlaceSearch, with_estimate: bool = True) -> int:
        """Enter the estimate's place and every place the search found explaining the recent scans within
        LEDGER_MARGIN of it into the ledger, those it does not follow yet as likely as the estimate (the
        search's own scores are no evidence: a refinement caught in a local optimum scored the true place 0.27
        per beam below its rotated copy), so that the scans from now on weigh them. Without the estimate (the
        particles do not agree on a place yet): every place the search found, as likely as each other. Returns
        the estimate's entry (-1 without it)."""
        ledger = self._ledger
        if not with_estimate:
            for place in search.poses:
                ledger.add(place, float(ledger.evidence.max()) if len(ledger) else 0.0)
            return -1
        if ledger.find(search.own_pose) < 0:  # not followed yet: as good as the best until the scans say otherwise
            ledger.add(search.own_pose, float(ledger.evidence.max()) if len(ledger) else 0.0)
        own_evidence = float(ledger.evidence[ledger.find(search.own_pose)])
        for place, score in zip(search.poses, search.scores):
            if score >= search.own_score - LEDGER_MARGIN:
                ledger.add(place, own_evidence)
        return ledger.find(search.own_pose)

    def _weigh_rivals(self, search: PlaceSearch) -> tuple[np.ndarray, np.ndarray]:
        """The places explaining the recent scans as well as the estimate that the ledger's evidence does not rule
        out, and each one's odds against the estimate."""
        ledger = self._ledger
        own = self._follow(search)
        rivals = search.within(self._rival_params.margin)
        # a rival the ledger dropped (it holds max_entries places) counts as likely as the estimate
        evidence = np.array([ledger.evidence[i] if i >= 0 else ledger.evidence[own] for i in map(ledger.find, rivals)])
        best = max(float(ledger.evidence[own]), float(evidence.max(initial=-np.inf)))
        viable = evidence > best - ledger.params.threshold
        odds = np.exp(np.minimum(evidence[viable] - ledger.evidence[own], MAX_LOG_ODDS))
        return rivals[viable].reshape(-1, 3), odds

    def _with_withdrawn_place(self, pose: np.ndarray, rivals: np.ndarray,
                              odds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """While contested, the place localized was withdrawn from stays a rival of any other place until the
        ledger rules it out (its evidence there leaves out the beams reading short of the map, which another robot
        explains): the rival search alone weighs the recent scans, those on the other robots included, and a
        look-alike place with walls where they stand scored better than the true place, which was then given up
        in 1.6 s (issue 22's fleet)."""
        ledger = self._ledger
        if not self._contested or self._withdrawn_from is None or not len(ledger):
            return rivals, odds
        index, own = ledger.find(self._withdrawn_from), ledger.find(pose)
        if index < 0 or index == own or ledger.ruled_out()[index] or \
                ledger.near(pose[None, :], index)[0] or \
                (len(rivals) and ledger.near(np.asarray(rivals).reshape(-1, 3), index).any()):
            return rivals, odds
        own_evidence = float(ledger.evidence[own]) if own >= 0 else float(ledger.evidence.max())
        place_odds = math.exp(min(float(ledger.evidence[index]) - own_evidence, MAX_LOG_ODDS))
        return (np.vstack([np.asarray(rivals).reshape(-1, 3), ledger.poses[index][None, :]]),
                np.append(odds, place_odds))

    def _recheck(self, pose: np.ndarray) -> None:
        """While localized: does a place elsewhere explain the recent scans clearly better than the estimate?"""
        self._since_recheck = 0
        # every beam, those reading short at the estimate too: a robot kidnapped into a look-alike place shows it
        # in them (the hard_maze kidnapping was not withdrawn in 10 s without them)
        recent = self.recent_scans(whole=True)
        if not recent:  # beacons only: no scans to search with
            return
        better = find_rivals(self.free_space, self._scorer, self._coarse_scorer, recent, pose,
                             replace(self._rival_params, margin=-self.config.recheck_margin))
        if len(better) and len(recent) and any(snapshot.whole is not None for snapshot in self.recent_scans()):
            # ... but a place that wins only by explaining the beams on something not on the map (another robot
            # standing where it has a wall) is no rival: it must explain the other beams as well as the estimate
            kept = self.recent_scans()
            now = kept[-1].odometry
            own = float(history_score(self._scorer, pose[None, :], kept, now)[0])
            scores = history_score(self._scorer, better, kept, now)
            better = better[scores >= own].reshape(-1, 3)
        if len(better):
            self._localized = False
            self._contested, self._withdrawn_from = True, pose.copy()
            self.rivals = better
            self._adopt_rivals(better)
            self.status.event = (f"{len(better)} place(s) elsewhere explain the recent scans better than the "
                                 "estimate: localized withdrawn")

    def _adopt_rivals(self, rivals: np.ndarray, odds: np.ndarray | None = None) -> None:
        """Give every rival a cloud of particles as heavy as the current cluster times its odds against it
        (1: as likely, as far as we know)."""
        count = len(self.particles)
        spread = np.array([self.config.cluster_radius / 2.0, self.config.cluster_radius / 2.0, math.radians(3.0)])
        clouds = [self.particles]
        mass = float(self._clusters.weights[0]) if self._clusters.count else 1.0
        weights = [self.weights]
        odds = np.ones(len(rivals)) if odds is None else odds
        for rival, rival_odds in zip(rivals, odds):
            cloud = rival + self._rng.standard_normal((count, 3)) * spread
            cloud[:, 2] = wrap_angle(cloud[:, 2])
            clouds.append(cloud)
            weights.append(np.where(self.free_space.contains(cloud[:, 0], cloud[:, 1]), rival_odds * mass / count, 0.0))
        self.particles = np.concatenate(clouds)
        weights = np.concatenate(weights)
        self.weights = weights / weights.sum()
        self._clusters = cluster_particles(self.particles[:, :2], self.weights, self.config.cluster_radius,
                                           self.config.cluster_min_size)

    def _current_pose(self, odometry: tuple[float, float, float]) -> PoseEstimate:
        """The last filter estimate moved by the odometry since that update."""
        estimate = self._estimate
        if self._estimate_odometry is None:
            return estimate
        moved = relative_pose(self._estimate_odometry, odometry)
        x, y, theta = compose(np.array([[estimate.x, estimate.y, estimate.theta]]), moved)[0]
        return PoseEstimate(float(x), float(y), float(theta), estimate.covariance)
