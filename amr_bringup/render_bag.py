"""amr-render-bag: a recorded run drawn as the demo's maze figure.

    amr-render-bag out/run out/run.png                      # walls from the bag's /map
    amr-render-bag out/run out/run.png --world inner_maze.yaml
    python -m amr_bringup.render_bag out/run.mcap out/run.png

The walls come from --world (a world file or a map_server YAML) or, without it, from the first
/map the bag holds (a real robot's map_server or SLAM map); the LiDAR mounting from /tf_static
(base_footprint -> base_scan) when the bag has it. Exit status 2 with a message naming what is
missing or malformed.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from amr_bringup.bag_reader import read_bag, render_bag
from amr_maps.map_world import world_from_grid
from amr_maps.messages import grid_from_message
from amr_maps.occupancy_grid import MapError
from amr_maps.world import World, WorldError, load_world, resolve_world_path
from amr_simulation.config import LidarConfig

MAP_TOPIC = "/map"
TF_STATIC_TOPIC = "/tf_static"
SCAN_FRAME = "base_scan"


def bag_world(bag: str | Path, world: str | None) -> World:
    """--world when given, else the first /map of the bag as walls."""
    if world:
        return load_world(resolve_world_path(world))
    recording = read_bag(bag, (MAP_TOPIC,))
    if not recording.count(MAP_TOPIC):
        raise MapError(f"{bag}: no {MAP_TOPIC} in the bag: name the walls with --world")
    _, message = recording.topics[MAP_TOPIC][0]
    return world_from_grid(grid_from_message(message), name="map", source=f"{bag}:{MAP_TOPIC}")


def lidar_mounting(bag: str | Path, scan_frame: str = SCAN_FRAME) -> LidarConfig:
    """The LiDAR's x, y on the robot from the bag's /tf_static, else the TurtleBot3's default."""
    recording = read_bag(bag, (TF_STATIC_TOPIC,))
    for _, message in recording.topics.get(TF_STATIC_TOPIC, ()):
        for transform in message.transforms:
            if transform.child_frame_id == scan_frame:
                t = transform.transform.translation
                return LidarConfig(x=t.x, y=t.y)
    return LidarConfig()


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="amr-render-bag", description=__doc__.splitlines()[0])
    parser.add_argument("bag", help="the bag directory (out/run) or its name with .mcap")
    parser.add_argument("png", help="the figure to write")
    parser.add_argument("--world", help="walls: a world file or map_server YAML (default: the bag's /map)")
    parser.add_argument(
        "--pose-topic",
        help="the nav_msgs/Odometry topic of the path (default: /ground_truth, else /odom, else /odometry)",
    )
    options = parser.parse_args(argv)
    try:
        world = bag_world(options.bag, options.world)
        png = render_bag(options.bag, options.png, world, options.pose_topic, lidar_mounting(options.bag))
    except (MapError, WorldError, ValueError) as error:  # BagError is a ValueError
        print(f"amr-render-bag: {error}", file=sys.stderr)
        return 2
    print(f"amr-render-bag: wrote {png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
