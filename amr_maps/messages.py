"""OccupancyGrid <-> nav_msgs/OccupancyGrid: plain functions (message types only, no rclpy).

The message's `data` is the grid's row-major cells from cell (0, 0) (bottom-left), `info.origin` the
pose of that cell's lower-left corner (yaw 0 as a quaternion), width = columns, height = rows.
"""

from __future__ import annotations

import array

import numpy as np
from builtin_interfaces.msg import Time
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage

from amr_maps.occupancy_grid import MapError, OccupancyGrid
from amr_util.geometry import yaw_from_quaternion
from amr_util.messages import quaternion


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
    info.origin.orientation = quaternion(yaw)
    message.data = array.array("b", grid.data.tobytes())
    return message


def grid_from_message(message) -> OccupancyGrid:
    """The OccupancyGrid a nav_msgs/OccupancyGrid carries (an rclpy message or one a bag reader decoded):
    the one conversion every /map subscriber uses. MapError naming the field that is inconsistent; an
    empty frame_id is read as "map"."""
    info = message.info
    width, height = int(info.width), int(info.height)
    if len(message.data) != width * height:
        raise MapError(f"OccupancyGrid message: data has {len(message.data)} cells, info says {width} x {height}")
    q = info.origin.orientation
    if abs(q.x) > 1e-9 or abs(q.y) > 1e-9:
        raise MapError("OccupancyGrid message: info.origin.orientation must be a rotation about z")
    data = np.asarray(message.data, dtype=np.int8).reshape(height, width)  # array.array or numpy (rosbags)
    origin = (info.origin.position.x, info.origin.position.y, yaw_from_quaternion(q))
    return OccupancyGrid(data.copy(), info.resolution, origin, message.header.frame_id or "map")
