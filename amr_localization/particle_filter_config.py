"""Parameters of the particle filter, each stated once (type, default, range, live or structural,
description), with nav2 AMCL's names where AMCL has the same knob.

Names that differ from AMCL's: kld_epsilon and kld_delta (AMCL pf_err, and pf_z as a quantile),
lidar_x/lidar_y/lidar_yaw (AMCL reads the mount from tf), and the knobs AMCL has no counterpart for:
the two correlation lengths of the measurement model, the place hypotheses' probabilities
(localized_probability, release_probability) and the place search's budget.

Built from a flat dict (a node's parameters) by from_params: an unknown name, a wrong type or a
value out of range raises a ConfigError naming the key. Structural fields are the ones a
ParticleFilter builds objects from at construction (models, free space, recovery filter, RNG):
fixed for the filter's life; every live field is read at each update (ParticleFilter.retune).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from amr_util.parameter_spec import Config, ConfigError, parameter
from amr_util.robot_description import default_robot

LASER_MODEL_TYPES = ("likelihood_field", "beam")


@dataclass(frozen=True)
class ParticleFilterConfig(Config):
    # particle count: KLD-sampling between min and max (AMCL: pf_err, pf_z as kld_epsilon, 1 - kld_delta)
    min_particles: int = parameter(100, minimum=1, maximum=1_000_000, live=True)
    """particle count floor once a single place holds the belief (KLD sampling; AMCL min_particles)."""
    max_particles: int = parameter(5000, minimum=1, maximum=1_000_000, live=True)
    """particle count while the belief is spread over several places (AMCL max_particles)."""
    kld_epsilon: float = parameter(0.05, above=0.0, below=1.0, live=True)
    """KLD sampling: bound on the distribution error (AMCL pf_err)."""
    kld_delta: float = parameter(0.01, above=0.0, below=1.0, live=True)
    """KLD sampling: probability that the bound fails (AMCL pf_z is the upper 1 - kld_delta quantile of the
    standard normal: 0.99 for 0.01)."""
    # motion: filter updates when odometry has moved this much (AMCL update_min_d, update_min_a)
    update_min_d: float = parameter(0.02, minimum=0.0, maximum=10.0, live=True)
    """m of odometry translation before a filter update; AMCL update_min_d."""
    update_min_a: float = parameter(0.05, minimum=0.0, maximum=math.pi, live=True)
    """rad of odometry rotation before a filter update; AMCL update_min_a."""
    max_odometry_speed: float = parameter(2.0, minimum=0.01, maximum=100.0, live=True)
    """m/s: odometry moving faster than this between two observations (by their stamps; 20 Hz when none are given),
    and more than half a metre, is taken as a reset of odometry, not as motion."""
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
    # the scan's measurement model
    laser_model_type: str = parameter("likelihood_field", choices=LASER_MODEL_TYPES)
    """measurement model of the scan: likelihood_field or beam (AMCL laser_model_type)."""
    max_beams: int = parameter(60, minimum=1, maximum=10_000, live=True)
    """beams of each scan used, evenly spread over the valid returns; AMCL max_beams."""
    sigma_hit: float = parameter(0.05, minimum=0.001, maximum=10.0)
    """m, std of a beam end point's distance to the nearest obstacle; AMCL sigma_hit."""
    z_rand: float = parameter(0.1, minimum=0.0, maximum=0.99)
    """weight of the random term of the mixture (clutter, people, other robots, glass); the hit term has the rest,
    1 - z_rand (AMCL z_rand and z_hit)."""
    laser_likelihood_max_dist: float = parameter(2.0, minimum=0.01, maximum=100.0)
    """m, distance to obstacles beyond which the likelihood field is flat; AMCL laser_likelihood_max_dist."""
    beam_correlation_length: float = parameter(0.12, minimum=0.0, maximum=10.0, live=True)
    """m: the length over which two beams' errors are correlated, exp(-d / length) for end points d apart (sensor
    frame: the same stretch of wall, the same map error, the same person); a beam weighs 1 / the sum of its
    correlations in a scan's log-likelihood; 0 = every beam independent. A property of how well the map fits the
    world: 0.12 for a simulator's world (its own map), 0.5 for a real building (particle_filter_real.yaml)."""
    scan_correlation_distance: float = parameter(0.5, minimum=0.0, maximum=100.0, live=True)
    """m of travel (or this many x 1.5 rad of turning) over which two scans' errors stay correlated: a scan counts
    as the share of this the robot moved since the last scan used (all of it after this much travel); 0 = each
    scan counts fully. Twice the length over which a scan's evidence for its pose stays correlated (what the map
    lacks is seen scan after scan): 0.5 for a simulator's world, 2 for a real building (particle_filter_real.yaml)."""
    lidar_x: float = parameter(default_robot().lidar_x, minimum=-2.0, maximum=2.0)
    """m, base_scan in base_footprint (x); the robot description's by default."""
    lidar_y: float = parameter(default_robot().lidar_y, minimum=-2.0, maximum=2.0)
    """m, base_scan in base_footprint (y); the robot description's by default."""
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
    # place hypotheses (hypotheses.py)
    localized_probability: float = parameter(0.95, above=0.5, maximum=1.0, live=True)
    """localized is declared once the best place hypothesis holds this posterior probability ..."""
    release_probability: float = parameter(0.8, above=0.0, maximum=1.0, live=True)
    """... and withdrawn once it falls under this (hysteresis; at most localized_probability)."""
    place_search_budget: int = parameter(40_000, minimum=0, maximum=100_000_000, live=True)
    """branch-and-bound nodes the place search may expand per filter update (its proposals become hypotheses and
    particles); 0 = no place search (the particles alone propose places)."""
    seed: int = parameter(0, minimum=0, maximum=2**31 - 1)
    """seeds the filter's random stream: the same seed and inputs give the same estimates."""

    def validate(self) -> None:
        if self.max_particles < self.min_particles:
            raise ConfigError(
                f"max_particles: must be >= min_particles ({self.min_particles}), got {self.max_particles}"
            )
        if self.recovery_alpha_slow > self.recovery_alpha_fast:
            raise ConfigError(
                f"recovery_alpha_slow: needs 0 <= recovery_alpha_slow <= recovery_alpha_fast <= 1, "
                f"got {self.recovery_alpha_slow} > {self.recovery_alpha_fast}"
            )
        if self.release_probability > self.localized_probability:
            raise ConfigError(
                f"release_probability: must be <= localized_probability ({self.localized_probability}), "
                f"got {self.release_probability}"
            )
