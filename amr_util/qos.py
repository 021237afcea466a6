"""The QoS profiles of the suite's topics, in one place so that publishers and subscribers agree."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

SENSOR_DATA = qos_profile_sensor_data
"""Scans: best effort, depth 5 (REP 2003's sensor data profile; a late or lost scan is not resent)."""


def reliable(depth: int = 10) -> QoSProfile:
    """Commands, odometry, status: reliable, volatile, keep last `depth`."""
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)


LATCHED = QoSProfile(
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
    history=HistoryPolicy.KEEP_LAST,
)
"""Maps, paths and static transforms: latched (transient local, the last one kept), as map_server and
tf_static publish them: a subscriber that joins later still gets the last message."""
