"""Monte Carlo localization on an occupancy grid: global localization, tracking and recovery, one model.

Each call to update(odometry, scan=..., beacons=..., stamp=...) does, in this order:

1. motion: once odometry has moved update_min_d / update_min_a since the last filter update, every
   particle samples the accumulated increment (motion_model.py) and every place hypothesis moves by it;
   a particle whose end pose is not in free space has probability 0 (the map prior), a hypothesis once the
   scan has placed it (step 4).
   Odometry moving faster than max_odometry_speed, and more than RESET_MIN_JUMP, is a reset, not motion;
2. measurement: log w_i += g sum_k w_k log p(z_k | x_i), the likelihood field (or beam model) mixture
   with its hit and random terms, each beam weighted by how many others share its stretch of wall and the
   scan by how far the robot moved since the last one (beam_correlation.py); beacon ranges count fully.
   A measurement sharper than the particles can follow is applied in stages with resampling between them
   (progressive_correction.py), all of it in the end;
3. resampling, when N_eff < RESAMPLE_THRESHOLD N: systematic, to max_particles while the belief holds
   several places and to what KLD-sampling asks for once one place holds it, each particle moved by the
   regularized filter's kernel; a share drawn at random over free space when the likelihood collapsed
   (augmented MCL, recovery_alpha_slow / _fast);
4. place hypotheses (hypotheses.py): born from the particles' clusters and from the place search
   (amr_maps.scan_matcher: a budgeted branch-and-bound correlative search of the whole map on the window's
   scans), each fitted to the scan and scored by the same measurement model, with their posterior
   probabilities; the particles are made to agree with them (a likely place without particles gets a cloud).
   The window (the last WINDOW scans' worth of evidence, a new place is scored on) is placed by scan-matched
   odometry (scan_odometry.py); the places and the place search's proposals move by its increments;
5. the estimate: the best hypothesis's particles' weighted mean, fitted to the scan by the matcher, and their
   covariance. Its confidence is the best hypothesis's probability times the share of the belief the
   hypotheses hold, and 0 until a place search has covered the map (or a pose was given, or beacons were
   read): localized is declared at localized_probability and withdrawn under release_probability.

Between filter updates the estimate follows odometry, so every call returns a finite pose.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Sequence
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from amr_localization.augmented_mcl import RecoveryRate
from amr_localization.beacons import BeaconReading, beacon_log_likelihood, checked_beacons, same_beacons
from amr_localization.beam_correlation import beam_weights, beams_in_view, scan_weight
from amr_localization.beam_model import BeamModel, BeamModelParams
from amr_localization.clustering import cluster_particles
from amr_localization.distance_field import DistanceField
from amr_localization.errors import BeaconError, LocalizationError, OdometryError
from amr_localization.free_space import FreeSpace
from amr_localization.helper_threads import submit
from amr_localization.hypotheses import MAX_HYPOTHESES, MERGE_ANGLE, MERGE_DISTANCE, PlaceHypotheses, place_index
from amr_localization.kld_sampling import kld_sample_count, occupied_bins
from amr_localization.likelihood_field import SPLIT_PARTICLES, FixedPoses, LikelihoodField, LikelihoodFieldParams
from amr_localization.motion_model import (
    OdometryNoise,
    motion_covariance,
    motion_variance,
    sample_motion_model_odometry,
)
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_localization.pose_estimate import PoseEstimate, grouped_covariances, weighted_pose
from amr_localization.progressive_correction import MAX_STAGES, stage_exponent
from amr_localization.resampling import effective_sample_size, jitter, systematic_resample
from amr_localization.scan_beams import Beams, select_beams
from amr_localization.scan_odometry import matched_increment
from amr_localization.sensor_mount import SensorMount
from amr_maps.occupancy_grid import OccupancyGrid
from amr_maps.scan_matcher import CorrelativeMatcher, GlobalSearch, ScoreMap, WindowMatch
from amr_util.geometry import compose, one_per_cell, relative_pose, transform_points, wrap_angle
from amr_util.robot_description import default_robot
from amr_util.scan import ScanData

KLD_BIN_SIZE = 0.1
"""m, x and y side of a KLD histogram bin (AMCL's 0.5 m is for 10 cm maps; the maze worlds are 2 cm)."""
KLD_BIN_ANGLE = math.radians(10.0)
"""rad, heading side of a KLD histogram bin (AMCL's)."""
RESAMPLE_THRESHOLD = 0.5
"""resample when the effective sample size falls under this share of the particles (and the progressive correction's
stages shrink it at most to this)."""
CLUSTER_RADIUS = 0.1
"""m: particles closer than this belong to one cluster (a place hypothesis is born from each)."""
CLUSTER_MIN_SIZE = 10
"""particles a cell needs to be part of a cluster (a place hypothesis's birth)."""
CLOUD_SPREAD = (0.05, 0.05, math.radians(3.0))
"""m, m, rad: std of the cloud a likely place without particles gets."""
MIN_CLOUD = 50
"""particles at least in such a cloud."""
WINDOW = 5.0
"""scans' worth of evidence (the sum of their scan weights: 5 scans a metre apart, or 1 m of a dense stream) kept
with their odometry and weights, that a new hypothesis is scored on against the strongest ..."""
WINDOW_SCANS = 200
"""... in at most this many scans."""
KIDNAP_LOG_PRIOR = -10.0
"""log-probability that the robot was carried, unseen, to a place no hypothesis followed: the prior of a place born
while the filter is localized, or while the place of a pose given (initialize_pose) is followed and not withdrawn."""
PLACE_SEARCH_CELLS = 250_000
"""the place search runs on the map max-pooled by the smallest whole factor that leaves at most this many cells (its
proposals are then fitted on the map itself) ... A search's proposals are carried by the scan-matched odometry from
its scan to the one it finishes on, so a search must finish within a few metres of travel: on a 60 m building, 0.3 m
cells (why: docs/decisions/2026-11-29-localization-one-model.md, fourth pass)."""
PLACE_SEARCH_MIN_CELL = 0.05
"""m: a map of finer cells is pooled for the place search by the largest whole factor that keeps its cells within
this (2 cm maps to 4 cm: fewer cells and headings, nothing the scans tell apart lost)."""
PLACE_SEARCH_RANGE = 10.0
"""m: ... with the beams ending within this of the LiDAR (the far ones set the angular step, not the place)."""
SEARCH_PROPOSALS = 4
"""places a completed place search proposes (the best by the measurement model of the SEARCH_CANDIDATES best poses of
its lattice), and the heaviest particle clusters proposed each update."""
SEARCH_CANDIDATES = 8
"""poses the place search keeps, best first by its lattice's score: a pooled lattice ranks look-alikes about alike
(on the logs a true place came 5th to 8th), so the measurement model chooses the proposals among them."""
RUNNING_PEAKS = 2
"""of a place search under way, its best poses so far that `elsewhere` is scored at (each fitted every update)."""
FIT_WINDOW = 0.06
"""m: a place hypothesis is fitted to each scan within this of its pose (odometry's drift between two updates) ..."""
FIT_ANGLE = math.radians(4.0)
"""rad: ... and this of its heading."""
REFIT_WINDOW = 0.1
"""m: a place search's proposals are refitted within 3 sigma of the odometry's position since its scan, up to this,
and at least within the search's cell (a lattice pose is up to a cell off: within FIT_ANGLE in heading)."""
FREE_PATH_MARGIN = 0.1
"""m: a beam of a place hypothesis that goes through a wall of the map this far short of its end point reads as a
random reading (LikelihoodField.log_likelihood_free_path)."""
NUDGES = np.array([(i, j, k) for k in (-1, 0, 1) for i in (-1, 0, 1) for j in (-1, 0, 1)], dtype=float)
"""offsets (in cells and half degrees) within which each beam of a place hypothesis is scored at its best (the
heading slowest: LikelihoodField.best_free_path turns a beam once per heading)."""
ANYWHERE = 64
"""poses spread over free space (fixed per filter) on which the data's marginal likelihood over the map is estimated
(the `elsewhere` hypothesis: hypotheses.py)."""
CHAIN_RESOLUTION = 0.05
"""m: cells of the scan-to-scan match that places the window's scans (at least the map's)."""
RESET_MIN_JUMP = 0.5
"""m: odometry moving less than this is motion whatever the stamps say (a reset must also be too fast: the motion
model's noise and the scans absorb a small jump, while a real motion taken as a reset is lost; intel's stamps put
two scans 0.01 s apart across a 29-degree turn)."""
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
    """A scan used, for scoring hypotheses born later: the odometry then, its beams, their weights, its gain; its
    end points (robot frame, within PLACE_SEARCH_RANGE, one per CHAIN_RESOLUTION cell), its pose in the window's
    frame (placed by scan-matched odometry: scan_odometry), and the beams' end points (robot frame: the places' fits
    and the place search match them)."""

    odometry: tuple[float, float, float]
    beams: Beams
    weights: np.ndarray
    gain: float
    points: np.ndarray
    local: tuple[float, float, float]
    beam_points: np.ndarray


class _Ahead:
    """A call run on a helper thread (helper_threads), started now and collected by `result` (its exception raised
    there): work that needs only what is known now, done on the second core while this thread goes on (its compiled
    kernels release the GIL). The same call, the same result. here: run it now on this thread instead (nothing to
    hide it behind: the hand-off would cost more than it saves)."""

    def __init__(self, function, *args, here: bool = False) -> None:
        if not here:
            self._future = submit(function, *args)
            return
        self._future = Future()
        try:
            self._future.set_result(function(*args))
        except Exception as error:  # raised where it is collected, as from a helper
            self._future.set_exception(error)

    def result(self):
        return self._future.result()


SEARCH_TURN = math.pi / 4
"""rad of turn since the last place search that, like scan_correlation_distance of travel, starts a new one."""


@dataclass
class _Search:
    """A place search under way: its scan's pose in the window's frame (its proposals are moved by the scan-matched
    odometry since), and the variances (m^2, rad^2) the odometry motion model has accumulated since (they are
    refitted within 3 sigma of its position)."""

    search: GlobalSearch
    local: tuple[float, float, float]
    position_variance: float = 0.0
    heading_variance: float = 0.0
    ahead: Future | None = None

    def moved(self, increment, noise) -> None:
        """The motion model's noise over one more odometry increment (motion_variance)."""
        position, heading = motion_variance(increment, noise, self.heading_variance)
        self.position_variance += position
        self.heading_variance += heading

    def advance(self, budget: int) -> None:
        """The search's next `budget` nodes: those started ahead after the last update, or now."""
        if self.ahead is not None:
            self.ahead.result()
            self.ahead = None
        else:
            self.search.advance(budget)

    def start_ahead(self, budget: int) -> None:
        """The next `budget` nodes on a helper thread, started now and collected by the next `advance`: the compiled
        branch and bound runs without the GIL while the rest of this update and the wait for the next scan go on (the
        nodes and their order are those `advance` would score then: the same proposals)."""
        self.ahead = submit(self.search.advance, budget)


class ParticleFilter:
    """MCL over one map. Not thread-safe: one caller at a time."""

    def __init__(
        self,
        grid: OccupancyGrid,
        config: ParticleFilterConfig | None = None,
        range_max: float | None = None,
        beacons: Sequence[Sequence[float]] | None = None,
    ) -> None:
        self.config = config = config or ParticleFilterConfig()
        range_max = default_robot().lidar_range_max if range_max is None else range_max
        self.field = DistanceField(grid)
        self.free_space = FreeSpace(self.field, config.free_space_clearance)
        self._open_space = FreeSpace(self.field, 0.0)  # free cells: where a place hypothesis may be
        self.mount = SensorMount(config.lidar_x, config.lidar_y, config.lidar_yaw)
        self.noise = OdometryNoise(config.alpha1, config.alpha2, config.alpha3, config.alpha4)
        if config.laser_model_type == "beam":
            self._laser = BeamModel(self.field, BeamModelParams(sigma_hit=config.sigma_hit), self.mount)
        else:
            params = LikelihoodFieldParams(
                config.sigma_hit, 1.0 - config.z_rand, config.z_rand, config.laser_likelihood_max_dist
            )
            self._laser = LikelihoodField(self.field, params, self.mount, range_max)
        self._grid = grid
        self._matcher: CorrelativeMatcher | None = None
        self._coarse: tuple[CorrelativeMatcher, np.ndarray] | None = None  # the place search's
        if config.place_search_budget > 0 and config.laser_model_type == "likelihood_field" and range_max > 0:
            # built here, with the likelihood field, not in the first update (whose time it would be)
            self._matcher = self._new_matcher()
            self._place_search_map()
        self.beacons = checked_beacons(beacons) if beacons is not None else None
        self._recovery = RecoveryRate(config.recovery_alpha_slow, config.recovery_alpha_fast)
        self._rng = np.random.default_rng(config.seed)
        self._odometry: tuple[float, float, float] | None = None  # odometry at the last filter update
        self._stamp: float | None = None
        self.hypotheses = PlaceHypotheses()
        self._anywhere = self.free_space.sample(ANYWHERE, np.random.default_rng(config.seed))
        self._anywhere_paths = (
            self._laser.fixed_poses(self._anywhere, NUDGES * self._nudge_step)
            if isinstance(self._laser, LikelihoodField)
            else None
        )
        self._window: deque[_Seen] = deque(maxlen=WINDOW_SCANS)
        self._scores: dict[int, tuple[_Seen, dict[bytes, float]]] = {}  # _place_scores' memo, the update's scans'
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
        the one place hypothesis until the scans propose others, and the prior against them while it is followed
        (a place born meanwhile has KIDNAP_LOG_PRIOR)."""
        if not all(map(math.isfinite, (x, y, theta))):
            raise LocalizationError(f"initial pose: must be finite, got ({x}, {y}, {theta})")
        covariance = (
            np.diag([0.25**2, 0.25**2, (math.pi / 12) ** 2]) if covariance is None else np.asarray(covariance, float)
        )
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
        self._given = int(self.hypotheses.ids[0])
        self._covered = True  # the given pose is the prior: no place elsewhere needs searching first

    def _reset_belief(self) -> None:
        self.weights = np.full(len(self.particles), 1.0 / len(self.particles))
        self._recovery.reset()
        self._localized = False
        self._declared: int | None = None  # the place (PlaceHypotheses.ids) localized was declared at
        self._given: int | None = None  # the place of a pose given (initialize_pose), till withdrawn or forgotten
        self._pending_measurement = True
        self._moved = (0.0, 0.0)  # m and rad since the last scan used
        self._estimate_odometry = self._odometry
        self._search: _Search | None = None
        self._searched_from: np.ndarray | None = None
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
        selected = (
            select_beams(scan, self.config.max_beams, self.config.laser_model_type == "beam")
            if scan is not None
            else None
        )
        if beacons is not None and self.beacons is None:
            raise BeaconError("beacon ranges: this filter was built without beacon positions")
        if beacons is not None and len(beacons.ranges) != len(self.beacons):
            raise BeaconError(f"beacon ranges: expected {len(self.beacons)} values, got {len(beacons.ranges)}")
        previous = self.status
        self.status = FilterStatus(
            particles=len(self.particles),
            clusters=len(self.hypotheses),
            effective_sample_size=previous.effective_sample_size,
            confidence=previous.confidence,
            runner_up=previous.runner_up,
        )
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
            self._measure(selected, beacons, scan if selected is not None else None)
        self.status.update_time = time.process_time() - started
        return Estimate(self._current_pose(odometry), self._localized, self.status)

    def _predict(self, odometry: tuple[float, float, float], elapsed: float) -> None:
        increment = relative_pose(self._odometry, odometry)
        d_trans = math.hypot(increment[0], increment[1])
        d_theta = abs(float(increment[2]))
        if d_trans > max(self.config.max_odometry_speed * max(elapsed, DEFAULT_PERIOD), RESET_MIN_JUMP):
            # a robot does not move this fast: odometry was reset or is corrupt. Re-anchor so that the pose reported
            # stays where it was: est_odom' = new (+) old^-1 (+) est_odom
            if self._estimate_odometry is not None:
                since_estimate = relative_pose(self._odometry, self._estimate_odometry)
                self._estimate_odometry = tuple(compose(np.array([odometry]), since_estimate)[0])
            self._odometry = odometry
            self.status.event = (
                f"odometry jumped {d_trans:.2f} m in {elapsed:.2f} s: taken as a reset, not as motion; "
                "the filter carries on from here"
            )
            return
        if d_trans < self.config.update_min_d and d_theta < self.config.update_min_a:
            return
        moved = sample_motion_model_odometry(self.particles, self._odometry, odometry, self.noise, self._rng)
        alive = self.free_space.contains(moved[:, 0], moved[:, 1])
        self.particles = moved
        self.status.killed = int(np.count_nonzero(~alive & (self.weights > 0.0)))
        self.weights = np.where(alive, self.weights, 0.0)
        self.hypotheses.move(increment, motion_variance(increment, self.noise)[0])
        if self._search is not None:
            self._search.moved(increment, self.noise)
        self._moved = (self._moved[0] + d_trans, self._moved[1] + d_theta)
        self._odometry = odometry
        self._pending_measurement = True
        if not self.weights.any():
            self.reinitialize_global()
            self.status.event = "every particle moved out of free space: global localization restarted"

    def _measure(self, beams: Beams | None, beacons: BeaconReading | None, scan: ScanData | None = None) -> None:
        config = self.config
        self._scores = {}
        seen = None
        used = 0.0
        if beams is not None:
            weights = beam_weights(beams, config.beam_correlation_length)
            gain = (
                scan_weight(*self._moved, config.scan_correlation_distance)
                if self._window or len(self.hypotheses)
                else 1.0
            )
            points = self._end_points(scan)
            # the scan's place in the window (the scan-matched odometry) on a helper thread while thousands of particles
            # weigh the scan's first stage, which needs it not (a few hundred take less than the hand-off); the places
            # need it before anything else (_placed_now)
            placed = _Ahead(self._placed, points, here=len(self.particles) < SPLIT_PARTICLES)
            seen = _Seen(self._odometry, beams, weights, gain, points, None, self._points(beams))
            used += gain * beams_in_view(weights)
            self.status.beams, self.status.scan_weight = beams_in_view(weights), gain
        if beacons is not None:
            used += len(self.beacons) + 1
            self._covered = True  # ranges to landmarks score every place of the map smoothly: no search needed
        if used <= 0.0:
            if seen is not None:  # the places still move by the scan-matched odometry
                self._rematch_places(seen._replace(local=placed.result()))
            return
        fits = background = None
        remaining = 1.0
        for stage in range(MAX_STAGES):
            log_likelihood = self._log_likelihood(self.particles, seen, beacons)
            alive = self.weights > 0.0
            log_prior = np.full(len(self.particles), -np.inf)
            log_prior[alive] = np.log(self.weights[alive])
            if stage == 0:
                # augmented MCL: the average per-beam likelihood (a geometric mean over the counted beams, so that it
                # neither underflows nor depends on the beam count), prior-weighted over the particles
                per_beam = np.exp(np.clip(log_likelihood / used, -700.0, 700.0))
                self._recovery.update(float(self.weights[alive] @ per_beam[alive] / self.weights[alive].sum()))
            step = (
                remaining
                if stage == MAX_STAGES - 1
                else stage_exponent(log_prior, log_likelihood, remaining, RESAMPLE_THRESHOLD)
            )
            log_weight = log_prior + step * log_likelihood
            peak = log_weight.max()
            if not math.isfinite(peak):
                for started in (placed if stage == 0 and seen is not None else None, fits, background):
                    if started is not None:
                        started.result()
                self.reinitialize_global()
                self.status.event = "no particle could explain the data: global localization restarted"
                return
            weights = np.exp(log_weight - peak)
            self.weights = weights / weights.sum()
            if stage == 0 and seen is not None:
                seen, fits, background = self._placed_now(seen, placed, beacons)
            remaining -= step
            if remaining <= 1e-9:
                break
            self._resample()  # between stages: the particles follow the part applied so far
        self._moved = (0.0, 0.0)
        self._pending_measurement = False
        neff = effective_sample_size(self.weights)
        self.status.effective_sample_size = neff
        if neff < RESAMPLE_THRESHOLD * len(self.particles):
            self._resample(self._sample_count())
        self._weigh_places(seen, beacons, fits, background)
        count = self._sample_count()
        if count < len(self.particles):  # KLD-sampling, on the places as they are now, asks for fewer particles
            self._resample(count)
        if seen is not None:
            self._window.append(seen)
            while sum(past.gain for past in self._window) - self._window[0].gain >= WINDOW:
                self._window.popleft()
        self._estimate_odometry = self._odometry
        self.status.updated = True
        self.status.particles = len(self.particles)
        self.status.clusters = len(self.hypotheses)

    def _placed_now(
        self, seen: _Seen, placed: _Ahead, beacons: BeaconReading | None
    ) -> tuple[_Seen, _Ahead | None, _Ahead | None]:
        """The scan placed in the window (`placed`, collected), the places moved by it (_rematch_places), a place search
        begun on it if one is due (_begin_search), and the places' fits to the scan and `elsewhere`'s background
        started: they need the scan and the places as they are now, not the particles, each on a helper thread while
        the particles weigh the scan's later stages. Returns the scan with its place, and the fits and background
        under way (None without places)."""
        seen = seen._replace(local=placed.result())
        self._rematch_places(seen)
        self._begin_search(seen)
        ahead = len(self.hypotheses) > 0
        fits = _Ahead(self._fitted_places, seen) if ahead else None
        background = _Ahead(self._background, seen, beacons) if ahead and self._anywhere_paths is not None else None
        return seen, fits, background

    # -- places -------------------------------------------------------------------------

    def _weigh_places(
        self,
        seen: _Seen | None,
        beacons: BeaconReading | None,
        fits: _Ahead | None = None,
        background: _Ahead | None = None,
    ) -> None:
        """Step 4: the hypotheses observe the data, new ones are born from the clusters and the place search, the
        particles are made to agree with their probabilities, and the estimate and localized follow. fits and
        background: the places' fits (_fitted_places) and `elsewhere`'s background (_background) under way, if
        started."""
        hypotheses = self.hypotheses
        none = np.zeros((0, 3))
        # the clusters' poses and the background of `elsewhere` need neither the place search nor the places' new
        # evidence: computed before the search's nodes are collected, which run on its thread meanwhile (and the
        # clusters' fits before the places' are collected, which run on theirs)
        clusters = cluster_particles(
            self.particles[:, :2], self.weights, CLUSTER_RADIUS, CLUSTER_MIN_SIZE, self.particles[:, 2]
        )
        candidates = [
            weighted_pose(self.particles[clusters.labels == label], self.weights[clusters.labels == label])
            for label in range(min(clusters.count, MAX_HYPOTHESES))
        ]
        poses = np.array([[c.x, c.y, c.theta] for c in candidates]).reshape(-1, 3)
        # a place born while localized elsewhere, or while the place of a pose given is followed, is one the robot
        # was carried to: the given pose is the prior, whether or not the scans have yet made it a declaration
        settled = self._localized or hypotheses.index_of(self._given) >= 0
        fit = np.zeros(len(poses))
        if seen is not None:
            # a cluster at no place yet is fitted within its own spread (up to a place's extent): a place is born
            # scored at its best pose, as the place search's proposals are, not at its particles' mean (a cluster 12 cm
            # and 3 deg off the truth scored 35 nats under it, and a symmetric room's copies born at their best kept
            # that lead); a cluster at a place followed is that place's candidate, fitted as the place is (wider, one
            # scan re-anchored orebro's place 10 deg off)
            spread = np.array([[c.position_std, c.heading_std] for c in candidates]).reshape(-1, 2)
            new = hypotheses.find(poses) < 0
            poses, fit = self._fitted(
                poses,
                seen,
                np.where(new, np.minimum(3.0 * spread[:, 0], MERGE_DISTANCE), 0.0),
                np.where(new, np.minimum(3.0 * spread[:, 1], MERGE_ANGLE), 0.0),
            )
        if len(hypotheses) and seen is not None:
            hypotheses.poses, held = fits.result() if fits is not None else self._fitted_places(seen)
        else:
            held = np.zeros(len(hypotheses))
        if len(hypotheses):
            # a place is impossible where its pose is in a wall (not merely near one): its pose as the data place it
            # (moved by the scan-matched odometry and fitted to the scan), not as odometry alone would, whose error
            # over a keyframe's metres can end in a wall beside the robot's true path
            inside = self._open_space.contains(hypotheses.poses[:, 0], hypotheses.poses[:, 1])
            hypotheses.keep(inside)
            held = held[inside]
        ahead = background.result() if background is not None else None
        if not len(hypotheses):
            background = 0.0
        else:
            background = ahead if ahead is not None else self._background(seen, beacons)
        found, found_fit, running = self._search_places(seen, held) if seen is not None else (none, np.zeros(0), none)
        if len(hypotheses):
            hypotheses.observe(
                held + self._log_likelihood(hypotheses.poses, None, beacons),
                self._elsewhere(seen, beacons, running, background),
            )
        if seen is not None:
            poses, fit = np.vstack([poses, found]), np.concatenate([fit, found_fit])
        self._admit(poses, fit + self._log_likelihood(poses, None, beacons), seen, beacons, settled)
        hypotheses.merge()
        self._agree()
        self._decide(seen)

    def _fitted_places(self, seen: _Seen) -> tuple[np.ndarray, np.ndarray]:
        """The places' poses fitted to the scan (_fitted) and the scan's log-likelihood at each: a place without
        particles, carried by odometry and the window's links alone, within 3 sigma of them."""
        window = np.minimum(3.0 * np.sqrt(self.hypotheses.variance), MERGE_DISTANCE)
        return self._fitted(self.hypotheses.poses, seen, window)

    def _admit(
        self, poses: np.ndarray, fit: np.ndarray, seen: _Seen | None, beacons: BeaconReading | None, settled: bool
    ) -> None:
        """Each candidate pose (`fit`: the data's log-likelihood there by the places' model) re-anchors the hypothesis
        it is where the data fit it better there (the best such candidate wins), or is born."""
        hypotheses = self.hypotheses
        index = hypotheses.find(poses)
        held = self._log_likelihood(hypotheses.poses, seen, beacons, places=True) if len(hypotheses) else fit[:0]
        for pose, which, score in zip(poses, index, fit, strict=True):
            if which >= 0 and score > held[which]:
                hypotheses.reanchor(int(which), pose)
                held[which] = score
        # the new places: a candidate within a place's extent (MERGE_DISTANCE and MERGE_ANGLE) of one born before it
        # is that place (by position alone, a cluster of particles turned 90 deg from the truth, listed first, kept
        # the place search's proposal of the truth 0.26 m away from being born)
        born = np.zeros((0, 3))
        for pose in poses[index < 0]:
            if place_index(pose, born)[0] < 0:
                born = np.vstack([born, pose])
        if not len(born):
            return
        if len(hypotheses):
            # at most as likely as the strongest: a place overtakes it only by the scans it is followed through; while
            # localized or from a pose given, a new place is one the robot was carried to (the kidnap prior)
            reference = hypotheses.poses[:1]
            gain = np.minimum(
                self._window_score(born, seen, beacons) - self._window_score(reference, seen, beacons)[0], 0.0
            ) + (KIDNAP_LOG_PRIOR if settled else 0.0)
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
            followed = target * len(self.particles) >= 1.0  # a particle's share or more: particles follow the place
            if followed:
                hypotheses.variance[index] = 0.0
            if mass > 0.0:
                self.weights[member] *= target / mass
            elif followed:
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
        """The estimate is the best hypothesis's particles' mean fitted to the scan, or the place's own pose where the
        data fit that better; localized follows its confidence with hysteresis."""
        config = self.config
        hypotheses = self.hypotheses
        if not len(hypotheses):
            self._estimate = weighted_pose(self.particles, self.weights)
            confidence = runner_up = 0.0
        else:
            member = hypotheses.find(self.particles) == 0
            self._estimate = (
                weighted_pose(self.particles[member], self.weights[member])
                if member.any()
                else PoseEstimate(*map(float, hypotheses.poses[0]), np.diag([MERGE_DISTANCE**2] * 2 + [MERGE_ANGLE**2]))
            )
            if seen is not None:
                particles = self._estimate
                self._estimate = self._refined(particles, seen)
                # the place's own pose where the data fit it better under the same prior as the refinement's (the
                # particles' mean, fitted within their spread, can lag a keyframe's odometry error the place's own fit
                # has taken out); without the prior, beams on objects the map lacks (other robots near a wall) pulled
                # the place along a wall the map's beams do not fix, 10-13 cm off while the particles stayed within 9
                place = hypotheses.poses[0]
                mean = np.array([self._estimate.x, self._estimate.y, self._estimate.theta])
                fit = self._log_likelihood(np.array([mean, place]), seen, None, places=True)
                if fit[1] - self._prior_cost(particles, place) > fit[0] - self._prior_cost(particles, mean):
                    self._estimate = PoseEstimate(*map(float, place), self._estimate.covariance)
            hypotheses.reanchor(0, np.array([self._estimate.x, self._estimate.y, self._estimate.theta]))
            held = (1.0 - self._outside) if self._covered else 0.0  # the belief the hypotheses hold
            confidence = float(self._shares[0]) * held
            runner_up = float(self._shares[1]) * held if len(self._shares) > 1 else 0.0
        threshold = config.release_probability if self._localized else config.localized_probability
        moved_on = self._localized and hypotheses.index_of(self._declared) != 0
        was_localized = self._localized
        self._localized = confidence >= threshold and not moved_on
        if was_localized and not self._localized:
            # a withdrawal doubts what the robot did before it (a kidnapping reads as odometry): places born from now
            # on are scored on the scans that come after, not on scans reached back through a move that never was;
            # and the places followed may no longer cover the map: a new declaration waits for a new place search; a
            # pose given is no longer the prior either (a declaration's kidnap prior ends here, and so does its)
            self._window.clear()
            self._covered, self._search = self.config.place_search_budget == 0, None
            self._searched_from = self._given = None
        if moved_on:  # the place declared is no longer the best: withdrawn; the new best must earn its own declaration
            self.status.event = "localized withdrawn: another place explains the scans better than the one declared"
        self._declared = int(hypotheses.ids[0]) if self._localized else None
        self.status.confidence, self.status.runner_up = confidence, runner_up

    def _background(self, seen: _Seen | None, beacons: BeaconReading | None) -> float:
        """The data's mean likelihood over the ANYWHERE poses (log): `elsewhere`'s background (_elsewhere)."""
        anywhere = self._log_likelihood(self._anywhere, seen, beacons, places=True, fixed=self._anywhere_paths)
        return float(np.logaddexp.reduce(anywhere) - math.log(len(anywhere)))

    def _elsewhere(
        self, seen: _Seen | None, beacons: BeaconReading | None, peaks: np.ndarray, background: float | None = None
    ) -> float:
        """The data's marginal log-likelihood over the places not followed (the places' own model),

            log (1/V) integral p(z | x) dx  ~  log( mean_m p(z | x_m) + sum_k p(z | x_k) v / V ),

        the ANYWHERE poses x_m drawn in free space for the background (_background, unless given), and for its
        peaks, which a few dozen poses drawn at random never meet (a scan is explained within centimetres and a degree
        of its pose), the running place search's best poses so far x_k (`peaks`, moved to now and fitted) that no place
        followed is at, each holding the share v / V of the map's poses a peak of the measurement model takes
        (_log_peak_share). A place followed that the robot is not at then loses to `elsewhere` as soon as the search
        meets where it is, not only once the search is complete."""
        background = self._background(seen, beacons) if background is None else background
        peaks = peaks[self.hypotheses.find(peaks) < 0] if len(peaks) else peaks
        if not len(peaks):
            return background
        at_peaks = self._log_likelihood(peaks, seen, beacons, places=True) + self._log_peak_share
        return float(np.logaddexp(background, np.logaddexp.reduce(at_peaks)))

    @property
    def _nudge_step(self) -> np.ndarray:
        """NUDGES' unit: a cell, a cell and half a degree."""
        return np.array([self._grid.resolution, self._grid.resolution, math.radians(0.5)])

    @property
    def _log_peak_share(self) -> float:
        """log v / V: the share of the map's poses (free area x 2 pi) within a cell and a degree of a pose, the width
        of the measurement model's peak as the places score it (each beam at its best within NUDGES)."""
        peak = self._grid.resolution**2 * math.radians(1.0)
        return math.log(peak / max(self.free_space.area * 2.0 * math.pi, peak))

    def _log_likelihood(
        self,
        poses: np.ndarray,
        seen: _Seen | None,
        beacons: BeaconReading | None,
        places: bool = False,
        fixed: FixedPoses | None = None,
    ) -> np.ndarray:
        """(H,) the data's log-likelihood at each pose, weighted as the particles' is. places: the likelihood field
        with the beam model's free path (LikelihoodField.log_likelihood_free_path: a beam through a wall of the map
        there scores as a random reading), for the few poses of place hypotheses; the particles' field alone scores
        a beam seen through a doorway as well at a look-alike place whose wall stands in the doorway. fixed: the
        same poses with their paths kept (LikelihoodField.fixed_poses), scored alike."""
        total = np.zeros(len(poses))
        if not len(poses):
            return total
        if seen is not None and places and isinstance(self._laser, LikelihoodField):
            # each beam at its best within a cell and half a degree of the pose (the map knows its walls to a cell): a
            # beam reads as going through a wall only where it does so from every one of these poses
            if fixed is not None:
                total += seen.gain * (fixed.best_free_path(seen.beams, FREE_PATH_MARGIN) @ seen.weights)
            else:
                total += seen.gain * self._place_scores(poses, seen)
        elif seen is not None:
            total += seen.gain * self._laser.log_likelihood(poses, seen.beams, seen.weights)
        if beacons is not None:
            total += beacon_log_likelihood(
                poses, self.beacons, beacons, self.config.beacon_sigma_range, self.config.beacon_sigma_compass
            )
        return total

    def _place_scores(self, poses: np.ndarray, seen: _Seen) -> np.ndarray:
        """(H,) the places' model's weighted sum of the scan's beam terms at each pose (LikelihoodField.best_free_path,
        NUDGES), each pose scored once per scan: a place is scored again and again within an update (fitted, then
        admitted, then decided on), at the very same pose."""
        poses = np.ascontiguousarray(poses, dtype=float)
        scores = self._scores.setdefault(id(seen), (seen, {}))[1]  # the scan held: its id is not reused meanwhile
        keys = [pose.tobytes() for pose in poses]
        new = [i for i, key in enumerate(keys) if key not in scores]
        if new:
            terms = self._laser.best_free_path(poses[new], NUDGES * self._nudge_step, seen.beams, FREE_PATH_MARGIN)
            scores.update(zip((keys[i] for i in new), terms @ seen.weights, strict=True))
        return np.array([scores[key] for key in keys])

    def _window_score(self, poses: np.ndarray, seen: _Seen | None, beacons: BeaconReading | None) -> np.ndarray:
        """(H,) the log-likelihood of the scans in the window and of the current data at each pose, the poses of
        the past scans reached back through the window's scan-matched odometry (a pose in a wall then scores as if it
        had seen nothing)."""
        total = self._log_likelihood(poses, seen, beacons, places=True)
        if not self._window:
            return total
        now = seen.local if seen is not None else self._now()
        for past in self._window:
            back = np.atleast_2d(compose(poses, relative_pose(now, past.local)))
            total += self._log_likelihood(back, past, None, places=True)
        return total

    def _end_points(self, scan: ScanData) -> np.ndarray:
        """(K, 2) the scan's end points in the robot's frame, within PLACE_SEARCH_RANGE, one per chain cell."""
        points = self._points(select_beams(scan, len(scan.ranges)))
        return one_per_cell(points[np.hypot(points[:, 0], points[:, 1]) <= PLACE_SEARCH_RANGE], self._chain_resolution)

    @property
    def _chain_resolution(self) -> float:
        return max(CHAIN_RESOLUTION, self._grid.resolution)

    def _placed(self, points: np.ndarray) -> tuple[float, float, float]:
        """The scan's pose in the window's frame: the last window scan's, moved by the odometry's increment since,
        matched and fused (scan_odometry.matched_increment); the odometry's own pose for the window's first."""
        if not self._window:
            return self._odometry
        last = self._window[-1]
        prior = np.asarray(relative_pose(last.odometry, self._odometry), dtype=float)
        increment = matched_increment(
            last.points,
            points,
            prior,
            motion_covariance(prior, self.noise),
            self._chain_resolution,
            self.config.beam_correlation_length,
        )
        return tuple(float(v) for v in np.asarray(compose(np.asarray(last.local), increment)).reshape(3))

    def _rematch_places(self, seen: _Seen) -> None:
        """The places, moved by the odometry since the window's last scan, moved by the scan-matched increment
        instead: the better estimate of the same motion (each place is then fitted to the scan within FIT_WINDOW,
        which a keyframe's odometry error can exceed)."""
        if not self._window:
            return
        last = self._window[-1]
        correction = relative_pose(relative_pose(last.odometry, self._odometry), relative_pose(last.local, seen.local))
        if len(self.hypotheses):
            self.hypotheses.poses = np.atleast_2d(compose(self.hypotheses.poses, correction))

    def _now(self) -> tuple[float, float, float]:
        """The pose now in the window's frame, without a scan: the last window scan's moved by odometry since."""
        last = self._window[-1]
        return tuple(np.asarray(compose(np.asarray(last.local), relative_pose(last.odometry, self._odometry))))

    @property
    def matcher(self) -> CorrelativeMatcher:
        """The scan-to-map matcher of the place search and the estimate's refinement (built at first use)."""
        if self._matcher is None:
            self._matcher = self._new_matcher()
        return self._matcher

    def _new_matcher(self) -> CorrelativeMatcher:
        sigma = max(self.config.sigma_hit, self._grid.resolution)
        return CorrelativeMatcher(ScoreMap.from_occupancy(self._grid, sigma=sigma))

    def _points(self, beams: Beams) -> np.ndarray:
        """(K, 2) the returned beams' end points in the robot's frame."""
        sensor = self.mount.sensor_poses(np.zeros((1, 3)))[0]  # the LiDAR in the robot's frame
        angles = sensor[2] + beams.angles[beams.returned]
        ranges = beams.ranges[beams.returned]
        return np.column_stack([sensor[0] + ranges * np.cos(angles), sensor[1] + ranges * np.sin(angles)])

    def _fitted(
        self, poses: np.ndarray, seen: _Seen, window: float | np.ndarray = 0.0, angle: float | np.ndarray = 0.0
    ) -> tuple[np.ndarray, np.ndarray]:
        """Each pose moved to where the scan fits best within `window` and `angle` of it, at least FIT_WINDOW and
        FIT_ANGLE (the matcher, below the cell): a place is scored at its best pose, so that two places the scans
        cannot tell apart score alike however their particles happen to spread. Returns the poses and the scan's
        log-likelihood at each by the places' model."""
        points = seen.beam_points
        poses = np.array(poses, dtype=float).reshape(-1, 3)
        fitted = poses.copy()
        windows = np.broadcast_to(np.maximum(window, FIT_WINDOW), (len(poses),))
        angles = np.broadcast_to(np.maximum(angle, FIT_ANGLE), (len(poses),))
        for row, pose in enumerate(poses):
            match = self.matcher.match(
                points, pose, float(windows[row]), float(angles[row]), refine=True, covariance_cells=0
            )
            if np.isfinite(match.pose).all():
                fitted[row] = match.pose[0], match.pose[1], float(wrap_angle(match.pose[2]))
        # the matcher's table is flat a wall thick: its fit is kept where the places' model scores it no lower
        score = self._log_likelihood(np.concatenate([fitted, poses]), seen, None, places=True)
        after, before = score[: len(poses)], score[len(poses) :]
        return np.where((after >= before)[:, None], fitted, poses), np.maximum(after, before)

    def _refined(self, estimate: PoseEstimate, seen: _Seen) -> PoseEstimate:
        """The estimate fitted to the scan: the matcher's best pose within the estimate's spread (at most the
        merge window), below the cell, where its likelihood by the places' model beats the particles' mean's by more
        than the move costs under the particles' Gaussian (their covariance, plus a cell and half a degree); the
        particles' estimate otherwise."""
        spread = min(3.0 * estimate.position_std + self._grid.resolution, MERGE_DISTANCE)
        turn = min(3.0 * estimate.heading_std + math.radians(1.0), MERGE_ANGLE)
        points = seen.beam_points
        pose = np.array([estimate.x, estimate.y, estimate.theta])
        # the match's covariance (the score surface around its lattice pose) only if its pose is kept (a fifth of the
        # updates on the logs): the same match, asked for it then
        search = WindowMatch(self.matcher, points, pose, spread, turn)
        search.advance(np.iinfo(np.int64).max)
        match = search.result(refine=True, covariance_cells=0)
        if not np.isfinite(match.pose).all() or match.score <= self.matcher.score_interpolated(points, pose):
            return estimate
        # the particles are the prior the scan refines: the matcher's pose is kept where the places' model scores it
        # above their mean by more than the particles' spread makes the move unlikely (the matcher alone slid 0.3 m
        # along a corridor, 5 of the particles' sigmas, for the beams on an object the map lacks)
        moved, stayed = self._log_likelihood(np.array([match.pose, pose]), seen, None, places=True)
        if not moved - self._prior_cost(estimate, match.pose) > stayed:
            return estimate
        surface = search.result(refine=False).covariance
        covariance = np.where(np.isfinite(surface), surface, estimate.covariance)
        return PoseEstimate(float(match.pose[0]), float(match.pose[1]), float(wrap_angle(match.pose[2])), covariance)

    def _prior_cost(self, particles: PoseEstimate, pose: np.ndarray) -> float:
        """The cost (nats) of moving the estimate from the particles' mean to `pose` under their Gaussian (their
        covariance plus the places' model's own precision, a cell and half a degree): the prior a fit to the scan
        is judged under."""
        offset = np.asarray(pose, dtype=float) - (particles.x, particles.y, particles.theta)
        offset[2] = wrap_angle(offset[2])
        floor = np.diag(self._nudge_step**2)
        return float(0.5 * offset @ np.linalg.solve(particles.covariance + floor, offset))

    def _search_places(self, seen: _Seen, held: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Proposals of the place search: a branch and bound over the whole map for the scan, place_search_budget
        nodes per update, resumed over updates (a scan's search finishes on later updates; its poses are moved by
        the odometry since). Returns the proposals of a search completed now and the scan's log-likelihood at each,
        and the best poses so far of one still running that no place followed is at (for `elsewhere`), each moved to
        now and fitted. A proposal at a place followed is that place as fitted this update (its pose, and `held`, the
        scan's log-likelihood there): fitted again from the proposal it would come to the same pose. Nothing when the
        budget is 0."""
        none = np.zeros((0, 3))
        budget = self.config.place_search_budget
        if budget <= 0:
            return none, np.zeros(0), none
        self._begin_search(seen)
        running = self._search
        if running is None:  # the last search's evidence still holds: none begun (_begin_search)
            return none, np.zeros(0), none
        running.advance(budget)
        done = running.search.done
        found = running.search.matches(refine=False, covariance_cells=0)
        poses = np.array([match.pose for match in found]).reshape(-1, 3)
        poses = np.atleast_2d(compose(poses, relative_pose(running.local, seen.local))).reshape(-1, 3)
        if not done:
            running.start_ahead(budget)
            poses = poses[:RUNNING_PEAKS]
            poses = poses[self.hypotheses.find(poses) < 0]
        else:
            self._search = None
            self._covered = True
        # moved by the scan-matched odometry since its scan, refitted within 3 sigma of it (to REFIT_WINDOW) or its cell
        window = max(min(3.0 * math.sqrt(running.position_variance), REFIT_WINDOW), self._place_search_resolution)
        if not done:
            return none, np.zeros(0), self._fitted(poses, seen, window)[0]
        place = self.hypotheses.find(poses)
        new = place < 0
        fitted, score = np.empty_like(poses), np.empty(len(poses))
        fitted[~new], score[~new] = self.hypotheses.poses[place[~new]], held[place[~new]]
        fitted[new], score[new] = self._fitted(poses[new], seen, window)
        best = np.argsort(-score, kind="stable")[:SEARCH_PROPOSALS]
        return fitted[best], score[best], none

    def _begin_search(self, seen: _Seen) -> None:
        """A new place search on the window's scans (_window_points), when none is under way: its first
        place_search_budget nodes started on its thread at once (_Search.start_ahead), once the scan is known to
        count, while the particles weigh it and the places are fitted (they need neither); _search_places collects
        them. The same nodes, in the same order, as run in _search_places itself: the same proposals."""
        budget = self.config.place_search_budget
        if budget <= 0 or self._search is not None:
            return
        last = self._searched_from
        if last is not None and self._covered:
            step = relative_pose(last, seen.local)
            if math.hypot(step[0], step[1]) < self.config.scan_correlation_distance and abs(step[2]) < SEARCH_TURN:
                return  # the window's evidence is mostly what the last search saw: its proposals stand
        self._searched_from = np.array(seen.local, dtype=float)
        matcher, region = self._place_search_map()
        points = self._window_points(seen, matcher.resolution)
        search = GlobalSearch(
            matcher,
            points,
            region,
            count=SEARCH_CANDIDATES,
            min_separation=2.0 * MERGE_DISTANCE,
            min_angle_separation=2.0 * MERGE_ANGLE,
        )
        self._search = _Search(search, seen.local)
        self._search.start_ahead(budget)

    def _window_points(self, seen: _Seen, resolution: float) -> np.ndarray:
        """(K, 2) the end points of the scan and of the window's scans before it, in the robot's frame now (the past
        ones placed by odometry), within PLACE_SEARCH_RANGE, one per cell of `resolution`: a few metres of travel
        seen at once, which tells look-alike places apart where a single scan cannot (a corridor's stretch, a
        room's doors), at the cost of a single scan's points."""
        clouds = [seen.beam_points]
        for past in self._window:
            clouds.append(transform_points(relative_pose(seen.local, past.local), past.beam_points))
        points = np.concatenate(clouds)
        return one_per_cell(points[np.hypot(points[:, 0], points[:, 1]) <= PLACE_SEARCH_RANGE], resolution)

    def _place_search_map(self) -> tuple[CorrelativeMatcher, np.ndarray]:
        """The place search's matcher and candidate cells: the map max-pooled to at most PLACE_SEARCH_CELLS cells (a
        cell is occupied where any of its cells is, a candidate where any of its cells is free space), built at first
        use. A coarse lattice has fewer cells and, with the points within PLACE_SEARCH_RANGE, fewer headings: a global
        search of a 60 m building in a few hundred thousand nodes instead of tens of millions; a maze of a few metres
        keeps cells of PLACE_SEARCH_MIN_CELL at most (coarser, its corridors would close)."""
        if self._coarse is None:
            grid = self._grid
            factor = max(
                math.ceil(math.sqrt(grid.height * grid.width / PLACE_SEARCH_CELLS)),
                int(PLACE_SEARCH_MIN_CELL / grid.resolution + 1e-9),
                1,
            )
            rows, cols = -(-grid.height // factor), -(-grid.width // factor)

            def pooled(mask: np.ndarray) -> np.ndarray:
                padded = np.zeros((rows * factor, cols * factor), dtype=bool)
                padded[: grid.height, : grid.width] = mask
                return padded.reshape(rows, factor, cols, factor).any(axis=(1, 3))

            occupied, known = pooled(grid.occupied()), pooled(grid.data >= 0)
            data = np.where(occupied, 100, np.where(known, 0, -1)).astype(np.int8)
            coarse = OccupancyGrid(data, grid.resolution * factor, grid.origin, grid.frame_id)
            sigma = max(self.config.sigma_hit, coarse.resolution)
            self._coarse = (
                CorrelativeMatcher(ScoreMap.from_occupancy(coarse, sigma=sigma)),
                pooled(self.free_space.mask) & ~occupied,
            )
        return self._coarse

    @property
    def _place_search_resolution(self) -> float:
        return self._place_search_map()[0].resolution

    def _sample_count(self) -> int:
        """max_particles while the belief is spread over several places (or not yet known to cover the map), else
        what KLD-sampling asks for the particles that would survive resampling."""
        config = self.config
        if not (
            self._covered
            and (len(self.hypotheses) == 1 or (len(self._shares) and self._shares[0] >= config.localized_probability))
        ):
            return config.max_particles
        bins = occupied_bins(self.particles[self.weights * len(self.particles) >= 1.0], KLD_BIN_SIZE, KLD_BIN_ANGLE)
        return min(
            max(kld_sample_count(bins, config.kld_epsilon, config.kld_delta), config.min_particles),
            config.max_particles,
        )

    def _resample(self, count: int | None = None) -> None:
        """Systematic resampling to `count` particles with augmented MCL's random ones; without a count (between the
        stages of a progressive correction) to as many as there are, none random."""
        inject = count is not None
        count = count if inject else len(self.particles)
        injected = int(round(self._recovery.injection_share() * count)) if inject else 0
        keep = systematic_resample(self.weights, count - injected, self._rng)
        self.particles = np.concatenate([self._regularized(keep), self.free_space.sample(injected, self._rng)])
        self.weights = np.full(count, 1.0 / count)
        self.status.injected = injected
        if injected:  # the injected guesses must be judged by the next measurement, not averaged away
            self._recovery.reset()

    def _regularized(self, keep: np.ndarray) -> np.ndarray:
        """The resampled particles, each moved by a draw of the regularized particle filter's kernel (Musso, Oudjane
        and Le Gland 2001): Gaussian, with the covariance of its place's weighted particles times h^2,
        h = (4 / (N (d + 2)))^(1 / (d + 4)), d = 3. Copies of one particle otherwise stay on one pose, and a narrow
        likelihood met by sparse particles (a first update over a whole map) would freeze the cloud a particle's
        spacing from the truth. Particles at no place hypothesis (the spread of global localization) stay as
        drawn; with no hypothesis yet, the whole cloud is one group. The kernel draws stay in free space (a draw
        outside keeps the particle where it was)."""
        chosen = self.particles[keep]
        # each particle's place; with no place yet (a global start), the whole cloud is one group
        owner = self.hypotheses.find(self.particles) if len(self.hypotheses) else np.zeros(len(self.particles), int)
        chosen_owner = owner[keep]
        bandwidth = (4.0 / (len(keep) * 5.0)) ** (1.0 / 7.0)
        places, factors = [], []
        drawn = np.bincount(chosen_owner + 1)[1:]  # each place's particles drawn (counts: no sort of thousands)
        chosen_places = np.flatnonzero(drawn)
        if len(chosen_places):
            covariances, counts = grouped_covariances(self.particles, self.weights, owner, int(chosen_places[-1]) + 1)
            for index in chosen_places:
                if counts[index] < 2:
                    continue
                try:
                    factors.append(np.linalg.cholesky(covariances[index] + 1e-12 * np.eye(3)))
                except np.linalg.LinAlgError:
                    continue
                places.append(index)
        if not places:
            return chosen
        # the kernel's draws, place by place (ascending), each place's rows in their order: one draw for them all
        places = np.array(places, dtype=np.int64)
        draws = self._rng.standard_normal((int(drawn[places].sum()), 3))
        grid = self.free_space.grid
        jitter(
            chosen,
            chosen_owner,
            places,
            np.array(factors),
            draws,
            bandwidth,
            self.free_space.mask,
            *grid.origin[:2],
            grid.resolution,
        )
        return chosen

    def _current_pose(self, odometry: tuple[float, float, float]) -> PoseEstimate:
        """The last filter estimate moved by the odometry since that update."""
        estimate = self._estimate
        if self._estimate_odometry is None:
            return estimate
        moved = relative_pose(self._estimate_odometry, odometry)
        x, y, theta = compose(np.array([[estimate.x, estimate.y, estimate.theta]]), moved)[0]
        return PoseEstimate(float(x), float(y), float(theta), estimate.covariance)
