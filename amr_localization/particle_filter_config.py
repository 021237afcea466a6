"""Parameters of the particle filter, with AMCL's names where AMCL has the same knob.

Built from a flat dict (a node's parameters) by from_params: an unknown name or a
value out of range raises a LocalizationError naming the key.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

from amr_localization.errors import LocalizationError

LASER_MODELS = ("likelihood_field", "beam")
BUILT_FIELDS = frozenset({
    "laser_model", "sigma_hit", "z_hit", "z_rand", "laser_likelihood_max_dist", "lidar_x", "lidar_y", "lidar_yaw",
    "free_space_clearance", "recovery_alpha_slow", "recovery_alpha_fast", "rival_margin", "rival_coarse_sigma",
    "history_length", "seed", "evidence_threshold", "evidence_dead_zone",
})
"""Fields a ParticleFilter builds objects from at construction (models, free space, recovery filter, RNG):
fixed for the filter's life; every other field is read at each update (ParticleFilter.retune)."""


@dataclass(frozen=True)
class ParticleFilterConfig:
    # particle count: KLD-sampling between min and max (AMCL: pf_err, pf_z as kld_epsilon, 1 - kld_delta)
    min_particles: int = 100
    max_particles: int = 5000
    kld_epsilon: float = 0.05
    kld_delta: float = 0.01
    kld_bin_size: float = 0.1
    """m, x and y side of a KLD histogram bin."""
    kld_bin_angle: float = math.radians(10.0)
    resample_threshold: float = 0.5
    """resample when N_eff < resample_threshold * N."""
    # motion: filter updates when odometry has moved this much (AMCL update_min_d, update_min_a)
    update_min_d: float = 0.02
    update_min_a: float = 0.05
    max_odometry_jump: float = 0.5
    """m of odometry between two calls beyond which it is taken as a reset, not as motion."""
    alpha1: float = 0.1
    alpha2: float = 0.1
    alpha3: float = 0.1
    alpha4: float = 0.1
    free_space_clearance: float = 0.08
    """m: particles live this far from walls at least (under the robot's radius, for map error)."""
    # laser
    laser_model: str = "likelihood_field"
    max_beams: int = 60
    sigma_hit: float = 0.05
    z_hit: float = 0.9
    z_rand: float = 0.1
    laser_likelihood_max_dist: float = 2.0
    likelihood_exponent: float = 0.1
    """a scan's log-likelihood is scaled by this (beams are correlated); beacon ranges count fully."""
    tempering_min_ess_ratio: float = 0.8
    """one update may shrink N_eff to this share at most: beta is lowered until it does not (tempering.py)."""
    lidar_x: float = 0.0
    lidar_y: float = 0.0
    lidar_yaw: float = 0.0
    # beacons
    beacon_sigma_range: float = 0.05
    beacon_sigma_compass: float = 0.05
    # augmented MCL
    recovery_alpha_slow: float = 0.001
    recovery_alpha_fast: float = 0.1
    # localized: one cluster holding the weight, tight, and the scan fits its pose
    cluster_radius: float = 0.1
    cluster_min_size: int = 10
    localized_min_cluster_share: float = 0.95
    localized_max_position_std: float = 0.05
    localized_max_heading_std: float = math.radians(5.0)
    localized_min_fit: float = 0.9
    fit_distance: float = 0.06
    localized_confirmations: int = 10
    """consecutive measurement updates meeting every condition before localized is declared."""
    lost_updates: int = 25
    """consecutive measurement updates with one cluster holding the weight while the scan does not fit it
    (fit < localized_min_fit) before the filter gives that cluster up and restarts global localization
    (a kidnapped robot; augmented MCL's few random particles rarely land near the truth); 0 = never."""
    # rival check before declaring (rival_check.py)
    rival_check: bool = True
    rival_margin: float = 0.05
    """per-beam log-likelihood: a rival scoring within this of the estimate makes the belief ambiguous."""
    rival_coarse_sigma: float = 0.1
    recheck_updates: int = 5
    """while localized, the rival search runs again every this many measurement updates; 0 = never."""
    recheck_margin: float = 0.15
    """per-beam log-likelihood: a place elsewhere explaining the recent scans better than the estimate by this
    much withdraws localized and gets particles (a robot kidnapped into a look-alike place; tracking the
    right place, the best rival scored at most 0.001 above the estimate, a kidnapped robot's true place
    0.2-0.35 above it within 5 s)."""
    evidence_threshold: float = 8.0
    """log-evidence (scan log-likelihoods x likelihood_exponent, summed since the evidence ledger began following
    a place): a place explaining the recent scans as well as the estimate but this far below it is ruled out
    (evidence_ledger.py)."""
    evidence_dead_zone: float = 1.0
    """log-likelihood: a beam whose term differs between two followed places by less than this adds no evidence
    to either (map and pose error stayed under 1.35, 99.9 % under 0.25, in symmetric rooms rasterized off the
    lattice; a feature's beams differ by 3-5.5)."""
    history_length: int = 10
    history_spacing: float = 0.1
    """m (or 2 x this in rad) of odometry between two scans kept for the rival check."""
    seed: int = 0

    def __post_init__(self) -> None:
        def need(ok: bool, name: str, problem: str) -> None:
            if not ok:
                raise LocalizationError(f"{name}: {problem}, got {getattr(self, name)!r}")

        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if field.type in ("float", float):
                need(isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value),
                     field.name, "must be a finite number")
            elif field.type in ("int", int):
                need(isinstance(value, int) and not isinstance(value, bool), field.name, "must be an integer")
        need(self.min_particles >= 1, "min_particles", "must be at least 1")
        need(self.max_particles >= self.min_particles, "max_particles", "must be >= min_particles")
        need(0.0 < self.kld_epsilon < 1.0, "kld_epsilon", "must be in (0, 1)")
        need(0.0 < self.kld_delta < 1.0, "kld_delta", "must be in (0, 1)")
        for name in ("kld_bin_size", "kld_bin_angle", "max_odometry_jump", "sigma_hit", "laser_likelihood_max_dist", "beacon_sigma_range",
                     "beacon_sigma_compass", "cluster_radius", "localized_max_position_std",
                     "localized_max_heading_std", "fit_distance", "likelihood_exponent"):
            need(getattr(self, name) > 0.0, name, "must be positive")
        for name in ("update_min_d", "update_min_a", "alpha1", "alpha2", "alpha3", "alpha4", "free_space_clearance",
                     "z_hit", "z_rand"):
            need(getattr(self, name) >= 0.0, name, "must be >= 0")
        need(0.0 < self.tempering_min_ess_ratio <= 1.0, "tempering_min_ess_ratio", "must be in (0, 1]")
        need(0.0 < self.resample_threshold <= 1.0, "resample_threshold", "must be in (0, 1]")
        need(self.laser_model in LASER_MODELS, "laser_model", f"must be one of {', '.join(LASER_MODELS)}")
        need(self.max_beams >= 1, "max_beams", "must be at least 1")
        need(0.0 <= self.recovery_alpha_slow <= self.recovery_alpha_fast <= 1.0, "recovery_alpha_slow",
             "needs 0 <= recovery_alpha_slow <= recovery_alpha_fast <= 1")
        need(self.cluster_min_size >= 1, "cluster_min_size", "must be at least 1")
        need(0.5 < self.localized_min_cluster_share <= 1.0, "localized_min_cluster_share", "must be in (0.5, 1]")
        need(0.0 <= self.localized_min_fit <= 1.0, "localized_min_fit", "must be in [0, 1]")
        need(self.history_length >= 1, "history_length", "must be at least 1")
        need(self.rival_margin >= 0.0, "rival_margin", "must be >= 0")
        need(self.rival_coarse_sigma > 0.0, "rival_coarse_sigma", "must be positive")
        need(self.history_spacing >= 0.0, "history_spacing", "must be >= 0")
        need(isinstance(self.rival_check, bool), "rival_check", "must be true or false")
        need(self.localized_confirmations >= 1, "localized_confirmations", "must be at least 1")
        need(self.lost_updates >= 0, "lost_updates", "must be >= 0 (0 = never restart)")
        need(self.recheck_updates >= 0, "recheck_updates", "must be >= 0 (0 = never)")
        need(self.recheck_margin >= 0.0, "recheck_margin", "must be >= 0")
        need(self.evidence_threshold > 0.0, "evidence_threshold", "must be positive")
        need(self.evidence_dead_zone >= 0.0, "evidence_dead_zone", "must be >= 0")

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> "ParticleFilterConfig":
        names = {field.name for field in dataclasses.fields(cls)}
        unknown = sorted(set(params) - names)
        if unknown:
            raise LocalizationError(f"{unknown[0]}: unknown particle filter parameter")
        values = {name: (float(v) if isinstance(v, int) and not isinstance(v, bool) and
                         cls.__dataclass_fields__[name].type in ("float", float) else v)
                  for name, v in params.items()}
        return cls(**values)
