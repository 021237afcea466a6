"""What the localizer nodes (particle_filter, beacon_localizer) share: a lifecycle shell that pairs
stamped inputs by the approximate-time policy and publishes an estimate the same way.

Inputs: each message's stamp is checked (malformed or negative: dropped with a warning) and handed to
amr_util.sync.ApproximateTimeSynchronizer (a pure algorithm module); stamps going back beyond
stamp_jump_threshold (a simulator reset) restart the pairing with a warning.
Outputs, all stamped with the observation's stamp: /pose (LocalizedPose in global_frame_id), map -> odom on
/tf (when tf_broadcast), ~/status (LocalizerStatus). A non-finite estimate is never published.
"""

from __future__ import annotations

import math

from builtin_interfaces.msg import Time as TimeMessage
from nav_msgs.msg import Odometry
from tf2_msgs.msg import TFMessage

from amr_interfaces.msg import LocalizedPose, LocalizerStatus
from amr_localization import messages
from amr_localization.pose_estimate import PoseEstimate
from amr_util.geometry import map_to_odom
from amr_util.managed_node import WARNING_PERIOD, ManagedNode
from amr_util.messages import transform
from amr_util.parameter_spec import ParameterSpec
from amr_util.qos import reliable
from amr_util.sync import ApproximateTimeSynchronizer

"""s between repeats of one kind of warning."""

SHELL_SPECS = (
    ParameterSpec(
        "global_frame_id",
        "map",
        "frame of /pose (and /particle_cloud): the parent of the published transform (AMCL global_frame_id)",
    ),
    ParameterSpec(
        "odom_frame_id", "odom", "frame of the odometry: the child of the published transform (AMCL odom_frame_id)"
    ),
    ParameterSpec(
        "tf_broadcast", True, "publish map -> odom on /tf after every observation processed (AMCL tf_broadcast)"
    ),
    ParameterSpec(
        "sync_slop", 0.05, "s, the stamps of paired inputs differ by at most this", minimum=0.0, maximum=100.0
    ),
    ParameterSpec("sync_queue_size", 10, "messages kept per input while pairing", minimum=1, maximum=1000),
    ParameterSpec(
        "stamp_jump_threshold",
        0.5,
        "s: stamps this much older than the last pair mean the clock jumped (a simulator reset): pairing starts afresh",
        minimum=0.01,
        maximum=3600.0,
    ),
)


class LocalizerNode(ManagedNode):
    """The shared shell; subclasses name their inputs (INPUTS) and build their own localizer."""

    INPUTS: tuple[str, ...] = ()

    def __init__(self, node_name: str, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self._sync: ApproximateTimeSynchronizer | None = None
        self._outputs: dict[str, object] = {}
        self._settings: dict = {}

    def _start_pairing(self, values: dict, callback) -> None:
        self._sync = ApproximateTimeSynchronizer(
            len(self.INPUTS),
            values["sync_slop"],
            values["sync_queue_size"],
            callback,
            jump_threshold=values["stamp_jump_threshold"],
            on_jump=self._on_clock_jump,
        )

    def _create_estimate_outputs(self, values: dict) -> None:
        self._outputs.update(
            {
                "pose": self.create_lifecycle_publisher(LocalizedPose, "pose", reliable()),
                "status": self.create_lifecycle_publisher(LocalizerStatus, "~/status", reliable()),
            }
        )
        if values["tf_broadcast"]:  # relative: /tf in the root namespace, /r1/tf for a robot of a fleet (as the
            # simulator publishes each robot's odom -> base_footprint, nav2's multi-robot layout)
            self._outputs["tf"] = self.create_lifecycle_publisher(TFMessage, "tf", reliable(100))

    def _on_message(self, index: int, message) -> None:
        self.feed_synchronizer(self._sync, index, message, self.warn_throttled)

    def _on_clock_jump(self, index: int, jump_ns: int) -> None:
        self.get_logger().warning(
            f"/{self.INPUTS[index]} stamps jumped by {jump_ns * 1e-9:+.3f} s: pairing restarted "
            "(the estimate is kept; an odometry reset is detected by its jump)"
        )

    def _publish_estimate(
        self, stamp: TimeMessage, odometry: Odometry, pose: PoseEstimate, localized: bool, status: LocalizerStatus
    ) -> bool:
        """/pose, map -> odom and ~/status for one observation; False (and nothing sent) if not finite."""
        if not messages.is_finite(pose):
            self.get_logger().error(
                "the estimate is not finite: nothing published", throttle_duration_sec=WARNING_PERIOD
            )
            return False
        frame = self._settings["global_frame_id"]
        self._outputs["pose"].publish(
            messages.localized_pose(stamp, frame, pose, localized, status.confidence, status.runner_up_confidence)
        )
        odom = messages.odometry_pose(odometry)
        if "tf" in self._outputs and all(map(math.isfinite, odom)):
            correction = map_to_odom((pose.x, pose.y, pose.theta), odom)
            self._outputs["tf"].publish(transform(stamp, frame, self._settings["odom_frame_id"], correction))
        status.header.stamp, status.header.frame_id = stamp, frame
        self._outputs["status"].publish(status)
        return True
