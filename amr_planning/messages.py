"""Messages of planning: a path as nav_msgs/Path (the planner's ~/plan answer, the navigator's /path)."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path

from amr_util.messages import quaternion


def path_message(points: np.ndarray, frame_id: str, stamp) -> Path:
    """nav_msgs/Path of (N, 2) points, each pose heading along the path (the last one as the one before)."""
    message = Path()
    message.header.stamp = stamp
    message.header.frame_id = frame_id
    points = np.asarray(points, dtype=float)
    headings = np.arctan2(*np.diff(points, axis=0).T[::-1]) if len(points) > 1 else np.zeros(1)
    headings = np.append(headings, headings[-1])[: len(points)]  # one per point (none for no points)
    for (x, y), heading in zip(points, headings, strict=True):
        pose = PoseStamped()
        pose.header = message.header
        pose.pose.position.x, pose.pose.position.y = float(x), float(y)
        pose.pose.orientation = quaternion(float(heading))
        message.poses.append(pose)
    return message
