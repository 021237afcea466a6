"""Parameters of the particle filter, each stated once (type, default, range, live or structural,
description), with nav2 AMCL's names where AMCL has the same knob.

Names that differ from AMCL's: kld_epsilon and kld_delta (AMCL pf_err, and pf_z as a quantile),
lidar_x/lidar_y/lidar_yaw (AMCL reads the mount from tf), and the knobs AMCL has no counterpart for
(tempering, clustering, the localized test, the rival check). The node's frame and map parameters
(global_frame_id, odom_frame_id, tf_broadcast, laser_max_range, map_topic) are AMCL's names too.

Built from a flat dict (a node's parameters) by from_params: an unknown name, a wrong type or a
value out of range raises a ConfigError naming the key. Structural fields are the ones a
ParticleFilter builds objects from at construction (models, free space, recovery filter, RNG):
fixed for the filter's life; every live field is read at each update (ParticleFilter.retune).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from amr_util.parameter_spec import Config, ConfigError, parameter

LASER_MODEL_TYPES = ("likelihood_field", "beam")


@dataclass(frozen=True)
class ParticleFilterConfig(Config):
    # particle count: KLD-sampling between min and max (AMCL: pf_err, pf_z as kld_epsilon, 1 - kld_delta)
    min_particles: int = parameter(100, minimum=1, maximum=1_000_000, live=True)
    """particle count floor once a single cluster remains (KLD sampling; AMCL min_particles)."""
    max_particles: int = parameter(5000, minimum=1, maximum=1_000_000, live=True)
    """particle count while spread (global localization; AMCL max_particles)."""
    kld_epsilon: float = parameter(0.05, above=0.0, below=1.0, live=True)
    """KLD sampling: bound on the distribution error (AMCL pf_err)."""
    kld_delta: float = parameter(0.01, above=0.0, below=1.0, live=True)
    """KLD sampling: probability that the bound fails (AMCL pf_z is the upper 1 - kld_delta quantile of the
    standard normal: 0.99 for 0.01)."""
    kld_bin_size: float = parameter(0.1, minimum=0.001, maximum=10.0, live=True)
    """m, x and y side of a KLD histogram bin."""
    kld_bin_angle: float = parameter(math.radians(10.0), minimum=0.001, maximum=math.pi, live=True)
    """rad, heading side of a KLD histogram bin."""
    resample_threshold: float = parameter(0.5, above=0.0, maximum=1.0, live=True)
    """resample when N_eff < resample_threshold * N."""
    # motion: filter updates when odometry has moved this much (AMCL update_min_d, update_min_a)
    update_min_d: float = parameter(0.02, minimum=0.0, maximum=10.0, live=True)
    """m of odometry translation before a filter update; AMCL update_min_d."""
    update_min_a: float = parameter(0.05, minimum=0.0, maximum=math.pi, live=True)
    """rad of odometry rotation before a filter update; AMCL update_min_a."""
    max_odometry_jump: float = parameter(0.5, minimum=0.01, maximum=100.0, live=True)
    """m of odometry between two calls beyond which it is taken as a reset, not as motion."""
    alpha1: float = parameter(0.1, minimum=0.0, maximum=10.0, live=True)
    """rotation noise from rotation (AMCL alpha1)."""
    alpha2: float = parameter(0.1, minimum=0.0, maximum=10.0, live=True)
    """rotation noise from translation (AMCL alpha2)."""
    alpha3: float = parameter(0.1, minimum=0.0, maximum=10.0, live=True)
    """translation noise from translation (AMCL alpha3)."""
    alpha4: float = parameter(0.1, minimum=0.0, maximum=10.0, live=True)
    """translation noise from rotation (AMCL alpha4)."""
    free_space_clearance: float = parameter(0.08, minimum=0.0, maximum=2.0)
    """m: particles live this far from walls at least (under the robot's radius, for map error)."""
    # laser
    laser_model_type: str = parameter("likelihood_field", choices=LASER_MODEL_TYPES)
    """measurement model of the scan: likelihood_field or beam (AMCL laser_model_type; no likelihood_field_prob)."""
    max_beams: int = parameter(60, minimum=1, maximum=10_000, live=True)
    """beams of each scan used, evenly spread over the valid returns; AMCL max_beams."""
    sigma_hit: float = parameter(0.05, minimum=0.001, maximum=10.0)
    """m, std of a beam end point's distance to the nearest obstacle; AMCL sigma_hit."""
    z_hit: float = parameter(0.9, minimum=0.0, maximum=1.0)
    """weight of the hit term of the likelihood field mixture; AMCL z_hit."""
    z_rand: float = parameter(0.1, minimum=0.0, maximum=1.0)
    """weight of the random term of the likelihood field mixture; AMCL z_rand."""
    laser_likelihood_max_dist: float = parameter(2.0, minimum=0.01, maximum=100.0)
    """m, distance to obstacles beyond which the field is flat; AMCL laser_likelihood_max_dist."""
    unexpected_obstacles: bool = parameter(True, live=True)
    """once one cluster holds unexpected_min_cluster_share of the weight, drop the beams reading
    unexpected_obstacle_margin or more short of the map's range at the estimate (other robots, people: not on the
    map) from the particles' weighting, the scan fit and the rival search (unexpected_obstacles.py)."""
    unexpected_obstacle_margin: float = parameter(0.15, minimum=0.01, maximum=10.0, live=True)
    """m: a beam this much shorter than the map's range at the estimate ended on something not on the map."""
    unexpected_obstacle_max_share: float = parameter(0.6, above=0.0, maximum=1.0, live=True)
    """when more of the returned beams than this share read short, none is dropped (the estimate is what is
    wrong: a kidnapped robot)."""
    unexpected_min_cluster_share: float = parameter(0.5, above=0.0, maximum=1.0, live=True)
    """the heaviest cluster's share of the weight before beams are judged against its estimate (while the
    particles are spread there is no estimate to judge by)."""
    see_through_check: bool = parameter(True, live=True)
    """no declaration of localized where more than see_through_max_share of the scan's returned beams read
    see_through_margin or more beyond the map's range at the estimate and at every pose within the declaration
    limits (localized_max_position_std, localized_max_heading_std) of it: they went through a wall of the map, so
    the place is not the robot's (other robots hiding the walls that tell it apart; unexpected_obstacles.py)."""
    see_through_margin: float = parameter(0.15, minimum=0.01, maximum=10.0, live=True)
    """m: a returned beam this much longer than the map's range went through a wall of the map."""
    see_through_max_share: float = parameter(0.05, minimum=0.0, maximum=1.0, live=True)
    """share of the returned beams that may read through a wall at a place localized is declared at."""
    likelihood_exponent: float = parameter(0.1, minimum=0.001, maximum=1.0, live=True)
    """a scan's log-likelihood is scaled by this (beams are correlated); beacon ranges count fully."""
    tempering_min_ess_ratio: float = parameter(0.8, above=0.0, maximum=1.0, live=True)
    """one update may shrink N_eff to this share at most: beta is lowered until it does not (tempering.py)."""
    lidar_x: float = parameter(0.0, minimum=-2.0, maximum=2.0)
    """m, base_scan in base_footprint (x)."""
    lidar_y: float = parameter(0.0, minimum=-2.0, maximum=2.0)
    """m, base_scan in base_footprint (y)."""
    lidar_yaw: float = parameter(0.0, minimum=-math.pi, maximum=math.pi)
    """rad, base_scan's yaw in base_footprint."""
    # beacons
    beacon_sigma_range: float = parameter(0.05, minimum=0.0001, maximum=10.0, live=True)
    """m, std of a beacon range."""
    beacon_sigma_compass: float = parameter(0.05, minimum=0.0001, maximum=math.pi, live=True)
    """rad, std of the compass."""
    # augmented MCL
    recovery_alpha_slow: float = parameter(0.001, minimum=0.0, maximum=1.0)
    """augmented MCL: slow average of the likelihood; AMCL recovery_alpha_slow."""
    recovery_alpha_fast: float = parameter(0.1, minimum=0.0, maximum=1.0)
    """augmented MCL: fast average of the likelihood; AMCL recovery_alpha_fast."""
    # localized: one cluster holding the weight, tight, and the scan fits its pose
    cluster_radius: float = parameter(0.1, minimum=0.001, maximum=10.0, live=True)
    """m, particles closer than this belong to one cluster."""
    cluster_min_size: int = parameter(10, minimum=1, maximum=100_000, live=True)
    """particles a cluster needs to count as a hypothesis."""
    localized_min_cluster_share: float = parameter(0.95, above=0.5, maximum=1.0, live=True)
    """weight one cluster must hold before localized is declared."""
    localized_max_position_std: float = parameter(0.05, minimum=0.001, maximum=10.0, live=True)
    """m, position spread of that cluster at most."""
    localized_max_heading_std: float = parameter(math.radians(5.0), minimum=0.001, maximum=math.pi, live=True)
    """rad, heading spread of that cluster at most."""
    localized_min_fit: float = parameter(0.9, minimum=0.0, maximum=1.0, live=True)
    """share of the scan's beams within fit_distance of a wall at the estimate."""
    fit_distance: float = parameter(0.06, minimum=0.001, maximum=1.0, live=True)
    """m, a beam end point this close to a wall fits."""
    localized_confirmations: int = parameter(10, minimum=1, maximum=10_000, live=True)
    """consecutive measurement updates meeting every condition before localized is declared."""
    lost_updates: int = parameter(25, minimum=0, maximum=100_000, live=True)
    """consecutive measurement updates with one cluster holding the weight while the scan does not fit it (fit <
    localized_min_fit) before the filter gives that cluster up and restarts global localization (a kidnapped
    robot; augmented MCL's few random particles rarely land near the truth); 0 = never."""
    # rival check before declaring (rival_check.py)
    rival_check: bool = parameter(True, live=True)
    """before declaring, search the map for other places that explain the recent scans as well."""
    rival_margin: float = parameter(0.05, minimum=0.0, maximum=10.0)
    """per-beam log-likelihood: a rival scoring within this of the estimate makes the belief ambiguous."""
    rival_coarse_sigma: float = parameter(0.1, minimum=0.001, maximum=10.0)
    """m, sigma_hit of the coarse likelihood field the rival search scores candidate places with."""
    recheck_updates: int = parameter(5, minimum=0, maximum=100_000, live=True)
    """while localized, the rival search runs again every this many measurement updates; 0 = never."""
    recheck_margin: float = parameter(0.15, minimum=0.0, maximum=10.0, live=True)
    """per-beam log-likelihood: a place elsewhere explaining the recent scans better than the estimate by this much
    withdraws localized and gets particles (a robot kidnapped into a look-alike place; tracking the right place,
    the best rival scored at most 0.001 above the estimate, a kidnapped robot's true place 0.2-0.35 above it
    within 5 s)."""
    evidence_threshold: float = parameter(8.0, minimum=0.1, maximum=1000.0)
    """log-evidence (scan log-likelihoods x likelihood_exponent, summed since the evidence ledger began following
    a place): a place explaining the recent scans as well as the estimate but this far below it is ruled out
    (evidence_ledger.py, docs/localization_symmetry.md)."""
    evidence_dead_zone: float = parameter(1.0, minimum=0.0, maximum=10.0)
    """log-likelihood: a beam whose term differs between two followed places by less than this adds no evidence
    to either (map and pose error stayed under 1.35, 99.9 % under 0.25, in symmetric rooms rasterized off the
    2 cm lattice; a feature's beams differ by 3-5.5)."""
    history_length: int = parameter(10, minimum=1, maximum=1000)
    """scans kept (history_spacing apart) for the rival check."""
    history_spacing: float = parameter(0.1, minimum=0.0, maximum=10.0, live=True)
    """m (or 2 x this in rad) of odometry between two scans kept for the rival check."""
    seed: int = parameter(0, minimum=0, maximum=2**31 - 1)
    """seeds the filter's random stream: the same seed and inputs give the same estimates."""

    def validate(self) -> None:
        if self.max_particles < self.min_particles:
            raise ConfigError(f"max_particles: must be >= min_particles ({self.min_particles}), got {self.max_particles}")
        if self.recovery_alpha_slow > self.recovery_alpha_fast:
            raise ConfigError(f"recovery_alpha_slow: needs 0 <= recovery_alpha_slow <= recovery_alpha_fast <= 1, "
                              f"got {self.recovery_alpha_slow} > {self.recovery_alpha_fast}")

