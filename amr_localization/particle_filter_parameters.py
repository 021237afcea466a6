"""The particle_filter node's ROS parameters: ParticleFilterConfig's (the filter's own, stated there) plus
the node's map source and inputs below, no ROS (amr_localization.localizer_node adds the shell's frames
and pairing).

Live parameters are read by the filter at every update (particle counts, thresholds, motion noise,
...); structural ones shape what configure builds (the map and its distance field, the laser model,
the sensor mount, the random stream, topics and frames) and are refused while configured.
"""

from __future__ import annotations

import dataclasses

from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_util.parameter_spec import ParameterSpec
from amr_util.robot_description import default_robot

NODE_SPECS = (
    ParameterSpec(
        "world",
        "",
        "the map as a simulator world file (rasterized at map_resolution): a name in "
        "share/amr_maps/config/worlds or a path; '' = map_yaml or the map topic",
    ),
    ParameterSpec(
        "map_yaml", "", "the map as a map_server YAML file (image + resolution + origin); '' = world or the map topic"
    ),
    ParameterSpec("map_resolution", 0.02, "m/cell at which a world is rasterized", minimum=0.005, maximum=1.0),
    ParameterSpec(
        "laser_max_range",
        default_robot().lidar_range_max,
        "m, the LiDAR's range_max, for the random term of the scan models (AMCL laser_max_range); the robot "
        "description's by default",
        minimum=0.01,
        maximum=1000.0,
    ),
    ParameterSpec("map_topic", "map", "nav_msgs/OccupancyGrid (transient local) used when world and map_yaml are ''"),
    ParameterSpec(
        "use_scan",
        True,
        "pair /scan (sensor_msgs/LaserScan) with /odometry and weigh the particles by "
        "the scan; false: no /scan subscription (a beacons-only filter, needs use_beacons)",
    ),
    ParameterSpec(
        "use_beacons",
        False,
        "pair /beacons (amr_interfaces/BeaconRanges) with /odometry (and /scan) and "
        "weigh the particles by the ranges and compass (beacon_sigma_range, beacon_sigma_compass); the "
        "beacon positions are the world's `beacons`, else the first reading's; a reading with other "
        "positions or a NaN range is refused",
    ),
    ParameterSpec(
        "particle_cloud_period",
        0.5,
        "s of scan time between two /particle_cloud messages (0: after every scan processed)",
        minimum=0.0,
        maximum=3600.0,
        live=True,
    ),
)


def parameter_specs() -> tuple[ParameterSpec, ...]:
    """The particle_filter node's own parameters (amr_localization.localizer_node adds the shell's)."""
    return ParticleFilterConfig.parameter_specs() + NODE_SPECS


def config_of(values: dict) -> ParticleFilterConfig:
    """The filter's configuration from the node's parameter values (the node's own keys left out)."""
    names = {field.name for field in dataclasses.fields(ParticleFilterConfig)}
    return ParticleFilterConfig.from_params({name: value for name, value in values.items() if name in names})
