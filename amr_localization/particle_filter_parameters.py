"""The particle_filter node's ROS parameters: one spec per ParticleFilterConfig field plus the node's own, no ROS.

Descriptions are the config's field docstrings (or the words below where a field has none); ranges
are the sensible limits a user sees in `ros2 param describe` (the config's own checks, e.g.
max_particles >= min_particles, still apply to the whole set). Live parameters are read by the
filter at every update (particle counts, thresholds, motion noise, ...); structural ones shape
what configure builds (the map and its distance field, the laser model, the sensor mount, the
random stream, topics and frames) and are refused while configured.
"""

from __future__ import annotations

import dataclasses
import math

from amr_localization.particle_filter_config import BUILT_FIELDS, LASER_MODELS, ParticleFilterConfig
from amr_util.parameter_spec import ParameterSpec, field_docs

DESCRIPTIONS = {
    "min_particles": "particle count floor once a single cluster remains (KLD sampling); AMCL min_particles",
    "max_particles": "particle count while spread (global localization); AMCL max_particles",
    "kld_epsilon": "KLD sampling: bound on the distribution error; AMCL pf_err",
    "kld_delta": "KLD sampling: probability the bound fails (AMCL pf_z is 1 - kld_delta's quantile)",
    "kld_bin_angle": "rad, heading side of a KLD histogram bin",
    "update_min_d": "m of odometry translation before a filter update; AMCL update_min_d",
    "update_min_a": "rad of odometry rotation before a filter update; AMCL update_min_a",
    "alpha1": "rotation noise from rotation (AMCL odom_alpha1)",
    "alpha2": "rotation noise from translation (AMCL odom_alpha2)",
    "alpha3": "translation noise from translation (AMCL odom_alpha3)",
    "alpha4": "translation noise from rotation (AMCL odom_alpha4)",
    "laser_model": "measurement model of the scan; AMCL laser_model_type",
    "max_beams": "beams of each scan used, evenly spread over the valid returns; AMCL max_beams",
    "sigma_hit": "m, std of a beam end point's distance to the nearest obstacle; AMCL sigma_hit",
    "z_hit": "weight of the hit term of the likelihood field mixture; AMCL z_hit",
    "z_rand": "weight of the random term of the likelihood field mixture; AMCL z_rand",
    "laser_likelihood_max_dist": "m, distance to obstacles beyond which the field is flat; AMCL laser_likelihood_max_dist",
    "lidar_x": "m, base_scan in base_footprint (x)", "lidar_y": "m, base_scan in base_footprint (y)",
    "lidar_yaw": "rad, base_scan's yaw in base_footprint",
    "beacon_sigma_range": "m, std of a beacon range", "beacon_sigma_compass": "rad, std of the compass",
    "recovery_alpha_slow": "augmented MCL: slow average of the likelihood; AMCL recovery_alpha_slow",
    "recovery_alpha_fast": "augmented MCL: fast average of the likelihood; AMCL recovery_alpha_fast",
    "cluster_radius": "m, particles closer than this belong to one cluster",
    "cluster_min_size": "particles a cluster needs to count as a hypothesis",
    "localized_min_cluster_share": "weight one cluster must hold before localized is declared",
    "localized_max_position_std": "m, position spread of that cluster at most",
    "localized_max_heading_std": "rad, heading spread of that cluster at most",
    "localized_min_fit": "share of the scan's beams within fit_distance of a wall at the estimate",
    "fit_distance": "m, a beam end point this close to a wall fits",
    "rival_check": "before declaring, search the map for other places that explain the recent scans as well",
    "rival_coarse_sigma": "m, sigma_hit of the coarse likelihood field the rival search scores candidate places with",
    "history_length": "scans kept (history_spacing apart) for the rival check",
    "seed": "seeds the filter's random stream: the same seed and inputs give the same estimates",
}
RANGES: dict[str, tuple[float, float]] = {
    "min_particles": (1, 1_000_000), "max_particles": (1, 1_000_000), "kld_epsilon": (1e-4, 0.999),
    "kld_delta": (1e-4, 0.999), "kld_bin_size": (0.001, 10.0), "kld_bin_angle": (0.001, math.pi),
    "resample_threshold": (0.01, 1.0), "update_min_d": (0.0, 10.0), "update_min_a": (0.0, math.pi),
    "max_odometry_jump": (0.01, 100.0), "alpha1": (0.0, 10.0), "alpha2": (0.0, 10.0), "alpha3": (0.0, 10.0),
    "alpha4": (0.0, 10.0), "free_space_clearance": (0.0, 2.0), "max_beams": (1, 10_000), "sigma_hit": (0.001, 10.0),
    "z_hit": (0.0, 1.0), "z_rand": (0.0, 1.0), "laser_likelihood_max_dist": (0.01, 100.0),
    "likelihood_exponent": (0.001, 1.0), "tempering_min_ess_ratio": (0.01, 1.0), "lidar_x": (-2.0, 2.0),
    "lidar_y": (-2.0, 2.0), "lidar_yaw": (-math.pi, math.pi), "beacon_sigma_range": (0.0001, 10.0),
    "beacon_sigma_compass": (0.0001, math.pi), "recovery_alpha_slow": (0.0, 1.0), "recovery_alpha_fast": (0.0, 1.0),
    "cluster_radius": (0.001, 10.0), "cluster_min_size": (1, 100_000), "localized_min_cluster_share": (0.51, 1.0),
    "localized_max_position_std": (0.001, 10.0), "localized_max_heading_std": (0.001, math.pi),
    "localized_min_fit": (0.0, 1.0), "fit_distance": (0.001, 1.0), "localized_confirmations": (1, 10_000),
    "lost_updates": (0, 100_000), "recheck_updates": (0, 100_000), "recheck_margin": (0.0, 10.0),
    "rival_margin": (0.0, 10.0), "rival_coarse_sigma": (0.001, 10.0), "history_length": (1, 1000),
    "history_spacing": (0.0, 10.0), "seed": (0, 2**31 - 1), "evidence_threshold": (0.1, 1000.0),
    "evidence_dead_zone": (0.0, 10.0),
}

NODE_SPECS = (
    ParameterSpec("world", "", "the map as a simulator world file (rasterized at map_resolution): a name in "
                  "share/amr_simulation/config/worlds or a path; '' = map_yaml or the map topic"),
    ParameterSpec("map_yaml", "", "the map as a map_server YAML file (image + resolution + origin); "
                  "'' = world or the map topic"),
    ParameterSpec("map_resolution", 0.02, "m/cell at which a world is rasterized", minimum=0.005, maximum=1.0),
    ParameterSpec("laser_max_range", 3.5, "m, the LiDAR's range_max, for the random term of the scan models "
                  "(AMCL laser_max_range)", minimum=0.01, maximum=1000.0),
    ParameterSpec("map_topic", "map", "nav_msgs/OccupancyGrid (transient local) used when world and map_yaml are ''"),
    ParameterSpec("use_scan", True, "pair /scan (sensor_msgs/LaserScan) with /odometry and weigh the particles by "
                  "the scan; false: no /scan subscription (a beacons-only filter, needs use_beacons)"),
    ParameterSpec("use_beacons", False, "pair /beacons (amr_interfaces/BeaconRanges) with /odometry (and /scan) and "
                  "weigh the particles by the ranges and compass (beacon_sigma_range, beacon_sigma_compass); the "
                  "beacon positions are the world's `beacons`, else the first reading's; a reading with other "
                  "positions or a NaN range is refused"),
    ParameterSpec("particle_cloud_period", 0.5, "s of scan time between two /particle_cloud messages "
                  "(0: after every scan processed)", minimum=0.0, maximum=3600.0, live=True),
)


def config_specs() -> tuple[ParameterSpec, ...]:
    """One spec per ParticleFilterConfig field, its default from the config."""
    docs = field_docs(ParticleFilterConfig)
    defaults = ParticleFilterConfig()
    specs = []
    for field in dataclasses.fields(ParticleFilterConfig):
        low, high = RANGES.get(field.name, (None, None))
        description = docs.get(field.name) or DESCRIPTIONS.get(field.name, "")
        specs.append(ParameterSpec(
            field.name, getattr(defaults, field.name), description, minimum=low, maximum=high,
            choices=LASER_MODELS if field.name == "laser_model" else (), live=field.name not in BUILT_FIELDS))
    return tuple(specs)


def parameter_specs() -> tuple[ParameterSpec, ...]:
    """The particle_filter node's own parameters (amr_localization.localizer_node adds the shell's)."""
    return config_specs() + NODE_SPECS


def config_of(values: dict) -> ParticleFilterConfig:
    """The filter's configuration from the node's parameter values (the node's own keys left out)."""
    names = {field.name for field in dataclasses.fields(ParticleFilterConfig)}
    return ParticleFilterConfig.from_params({name: value for name, value in values.items() if name in names})
