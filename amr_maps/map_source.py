"""Where map_server's map comes from: a map_server YAML, or a world file rasterized. No rclpy.

The node's parameters are stated here as ParameterSpecs, next to the loading they steer, so that
tests check both without ROS. Exactly one of `yaml_filename` and `world` names the map; every
problem is a MapError naming the file and the key.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from amr_maps.map_io import load_map
from amr_maps.occupancy_grid import MapError, OccupancyGrid
from amr_maps.rasterize import DEFAULT_RESOLUTION, rasterize_world
from amr_maps.world import WorldError, load_world, resolve_world_path
from amr_util.parameter_spec import ParameterSpec


def parameter_specs(world_problem: Callable[[str], str | None] | None = None) -> tuple[ParameterSpec, ...]:
    """Every parameter of the map_server node (all structural: the map is loaded at configure)."""
    return (
        ParameterSpec(
            "yaml_filename",
            "",
            "a map_server map file (name.yaml + its image), as nav2's map_server takes it; '' = use `world`",
        ),
        ParameterSpec(
            "world",
            "",
            "a world file (name in share/amr_maps/config/worlds, or a path), "
            "rasterized at `resolution`; '' = use `yaml_filename`",
            check=(lambda name: world_problem(name) if name and world_problem else None),
        ),
        ParameterSpec(
            "resolution",
            DEFAULT_RESOLUTION,
            "m per cell when the map is rasterized from `world`",
            minimum=0.001,
            maximum=10.0,
        ),
        ParameterSpec("frame_id", "map", "frame of the map (REP 105: map)"),
        ParameterSpec("topic_name", "map", "topic of the nav_msgs/OccupancyGrid (transient local)"),
    )


def load_grid(values: dict, world_dirs: Sequence[Path] = ()) -> OccupancyGrid:
    """The grid the parameter `values` name (a world name looked up in world_dirs, default
    amr_maps.world.world_search_path()); MapError naming the parameter, file and key on failure."""
    yaml_filename, world = values.get("yaml_filename", ""), values.get("world", "")
    frame_id = values.get("frame_id", "map")
    if bool(yaml_filename) == bool(world):
        raise MapError(
            "yaml_filename, world: give exactly one of them (a map file, or a world to rasterize), got "
            f"yaml_filename={yaml_filename!r}, world={world!r}"
        )
    if yaml_filename:
        try:
            return load_map(Path(yaml_filename).expanduser(), frame_id)
        except MapError as error:
            raise MapError(f"yaml_filename: {error}") from error
    try:
        loaded = load_world(resolve_world_path(world, world_dirs))
        return rasterize_world(loaded, values.get("resolution", DEFAULT_RESOLUTION), frame_id=frame_id)
    except (WorldError, MapError, OSError) as error:
        raise MapError(f"world: {error}") from error
