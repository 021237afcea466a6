"""OccupancyGrid <-> nav_msgs/OccupancyGrid: plain functions (message types only, no rclpy).

The message's `data` is the grid's row-major cells from cell (0, 0) (bottom-left), `info.origin` the
pose of that cell's lower-left corner (yaw 0 as a quaternion), width = columns, height = rows.
"""

from __future__ import annotations

import array
import math

import numpy as np
from builtin_interfaces.msg import Time
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage

from amr_maps.occupancy_grid import MapError, OccupancyGrid


def grid_message(grid: OccupancyGrid, stamp: Time, load_time: Time | None = None) -> OccupancyGridMessage:
    """nav_msgs/OccupancyGrid of `grid`, stamped `stamp`, loaded at `load_time` (default: the stamp)."""
    message = OccupancyGridMessage()
    message.header.stamp = stamp
    message.header.frame_id = grid.frame_id
    info = message.info
    info.map_load_time = load_time if load_time is not None else stamp
    info.resolution = grid.resolution
    info.width, info.height = grid.width, grid.height
    x, y, yaw = grid.origin
    info.origin.position.x, info.origin.position.y = x, y
    info.origin.orientation.w, info.origin.orientation.z = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    message.data = array.array("b", grid.data.tobytes())
    return message


def grid_from_message(message) -> OccupancyGrid:
    """The OccupancyGrid a nav_msgs/OccupancyGrid carries (an rclpy message or one a bag reader decoded);
    MapError naming the field that is inconsistent."""
    info = message.info
    if len(message.data) != info.width * info.height:
        raise MapError(f"OccupancyGrid message: data has {len(message.data)} cells, info says "
                       f"{info.width} x {info.height}")
    q = info.origin.orientation
    if abs(q.x) > 1e-9 or abs(q.y) > 1e-9:
        raise MapError("OccupancyGrid message: info.origin.orientation must be a rotation about z")
    yaw = 2.0 * math.atan2(q.z, q.w) if (q.z or q.w) else 0.0
    data = np.asarray(message.data, dtype=np.int8).reshape(info.height, info.width)  # array.array or numpy (rosbags)
    origin = (info.origin.position.x, info.origin.position.y, math.remainder(yaw, 2.0 * math.pi))
    return OccupancyGrid(data.copy(), info.resolution, origin, message.header.frame_id)
