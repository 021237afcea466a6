"""One time base and the standard views of a simulated stack: maze_sim composed, a late-joining probe on
every topic. The probe gates the lockstep loop (the wall follower's /cmd_vel is remapped to it and relayed
one step at a time), so "the latest /clock" is exact when a step's messages are checked."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from support.ros import spin_for, spin_until
from tf2_msgs.msg import TFMessage

from amr_bringup.composed import composed_stack
from amr_bringup.status import message_class
from amr_maps.rasterize import rasterize_world
from amr_maps.world import load_world, resolve_world_path
from amr_util.geometry import Pose2D, compose
from amr_util.geometry import yaw_from_quaternion as yaw
from amr_util.lean_executor import LeanExecutor
from amr_util.qos import LATCHED as LATCHED_QOS
from amr_util.qos import reliable
from amr_util.stamps import stamp_seconds as seconds

DT = 0.05
STEPS = 60
TIMEOUT = 10.0
LATCHED = ("/map", "/tf_static")
GATED = "/follower_cmd_vel"
WORLD = "outer_corridor.yaml"
LIDAR_MOUNTING = (-0.032, 0.0)  # config/simulator.yaml lidar.x, lidar.y


def stamps(message) -> list[float]:
    """Every header stamp a message carries (TFMessage: one per transform)."""
    if isinstance(message, TFMessage):
        return [seconds(t.header.stamp) for t in message.transforms]
    return [seconds(message.header.stamp)] if hasattr(message, "header") else []


class GateProbe(Node):
    """Subscribes to every topic of the graph; holds the follower's commands until relay()."""

    def __init__(self, context) -> None:
        super().__init__("time_base_probe", context=context)
        self.received: dict[str, list] = {}
        self.batch: list[tuple[str, object]] = []
        self.clock: float | None = None
        self.held: list[TwistStamped] = []
        self.cmd_vel = self.create_publisher(TwistStamped, "/cmd_vel", reliable(10))
        self.create_subscription(TwistStamped, GATED, self.held.append, reliable(10))
        self.subscribed: dict[str, object] = {}

    def subscribe_all(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self.subscribed or topic == GATED:
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            reliable_only = publishers and all(
                p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in publishers
            )  # best effort would drop some under load
            qos = (
                LATCHED_QOS
                if topic in LATCHED
                else QoSProfile(
                    depth=200,
                    reliability=ReliabilityPolicy.RELIABLE if reliable_only else ReliabilityPolicy.BEST_EFFORT,
                )
            )
            self.received[topic] = []
            self.subscribed[topic] = self.create_subscription(
                message_class(types[0]), topic, lambda message, topic=topic: self._on(topic, message), qos
            )

    def _on(self, topic: str, message) -> None:
        if topic == "/clock":
            self.clock = seconds(message.clock)
        self.received[topic].append(message)
        self.batch.append((topic, message))

    def count(self, topic: str) -> int:
        return len(self.received.get(topic, ()))


def test_every_stamp_is_simulated_time_and_map_tf_tf_static_are_right(ros_context):
    with composed_stack(
        ros_context,
        "maze_sim",
        arguments={"world": WORLD},
        parameters={"simulator.lockstep_resend_period": "0.0", "simulator.publish_map_to_odom": "true"},
        remappings={"wall_follower": (("cmd_vel", GATED),)},
    ) as (_, manager, _):
        assert all(step.ok for step in manager.startup()), "maze_sim did not come up"
        probe = GateProbe(ros_context)  # a late joiner: /map and /tf_static went out at activation
        executor = LeanExecutor(context=ros_context)
        executor.add_node(probe)
        try:
            probe.subscribe_all()
            assert spin_until(
                executor,
                lambda: (
                    probe.cmd_vel.get_subscription_count() > 0
                    and all(s.get_publisher_count() > 0 for s in probe.subscribed.values())
                ),
                TIMEOUT,
            )
            spin_for(executor, 0.3)  # matching settles
            kick = TwistStamped()  # the follower's answer to the first observation went out before we listened
            periodic: set[str] = set()
            checked: dict[str, int] = {}
            for step in range(STEPS):
                before = {topic: probe.count(topic) for topic in periodic}
                probe.cmd_vel.publish(probe.held.pop(0) if probe.held else kick)
                assert spin_until(
                    executor,
                    lambda before=before, periodic=periodic: (
                        probe.held and all(probe.count(t) > before[t] for t in periodic)
                    ),
                    TIMEOUT,
                ), f"step {step}: the loop stalled"
                if step == 0:  # the loop waits for the next command: what arrives now is the first step's
                    assert spin_until(executor, lambda: probe.clock is not None, TIMEOUT), "no /clock"
                    spin_for(executor, 0.3)
                    periodic = {t for t, _ in probe.batch if t not in LATCHED}
                clock = probe.clock
                assert clock is not None and clock == pytest.approx((step + 1) * DT, abs=1e-9)
                for topic, message in probe.batch + [(GATED, probe.held[0])]:
                    for stamp in stamps(message):
                        checked[topic] = checked.get(topic, 0) + 1
                        if topic in LATCHED:
                            assert stamp <= clock + 1e-9, (topic, stamp, clock)
                        else:
                            assert abs(stamp - clock) <= DT + 1e-9, f"{topic} stamped {stamp} at /clock {clock}"
                probe.batch.clear()
        finally:
            executor.remove_node(probe)
            probe.destroy_node()
            executor.shutdown()

    expected = {
        "/scan",
        "/odometry",
        "/odom",
        "/ground_truth",
        "/tf",
        "/tf_static",
        "/map",
        "/simulator/status",
        "/wall_follower/status",
        "/cmd_vel",
        GATED,
    }
    assert expected <= set(checked), f"no stamp checked on {sorted(expected - set(checked))}"
    assert checked["/scan"] >= STEPS

    # /map: latched for the late joiner, the rasterized world, in the map frame
    (grid,) = probe.received["/map"]
    world = rasterize_world(load_world(resolve_world_path(WORLD)), 0.05)
    assert grid.header.frame_id == "map" and grid.info.resolution == pytest.approx(0.05)
    assert (grid.info.origin.position.x, grid.info.origin.position.y) == pytest.approx(world.origin[:2])
    assert (grid.info.width, grid.info.height) == (world.width, world.height)
    assert np.array_equal(np.asarray(grid.data, dtype=np.int8), world.data.ravel())

    # /tf_static: the LiDAR mounting
    (static,) = probe.received["/tf_static"]
    (mounting,) = static.transforms
    assert (mounting.header.frame_id, mounting.child_frame_id) == ("base_footprint", "base_scan")
    t = mounting.transform.translation
    assert (t.x, t.y, t.z) == pytest.approx((*LIDAR_MOUNTING, 0.0)) and yaw(mounting.transform.rotation) == 0.0

    # /tf: odom -> base_footprint is /odometry's pose; map -> odom (+) odom -> base is /ground_truth
    odometry = {seconds(m.header.stamp): m.pose.pose for m in probe.received["/odometry"]}
    truth = {seconds(m.header.stamp): m.pose.pose for m in probe.received["/ground_truth"]}
    compared = 0
    for message in probe.received["/tf"]:
        frames = {(t.header.frame_id, t.child_frame_id): t for t in message.transforms}
        odom_base, map_odom = frames[("odom", "base_footprint")], frames[("map", "odom")]
        at = seconds(odom_base.header.stamp)
        if at not in odometry or at not in truth:
            continue
        pose = Pose2D(
            odom_base.transform.translation.x, odom_base.transform.translation.y, yaw(odom_base.transform.rotation)
        )
        p = odometry[at]
        assert (pose.x, pose.y, pose.theta) == pytest.approx(
            (p.position.x, p.position.y, yaw(p.orientation)), abs=1e-12
        )
        m = map_odom.transform
        composed = compose(Pose2D(m.translation.x, m.translation.y, yaw(m.rotation)), pose)
        g = truth[at]
        assert composed.x == pytest.approx(g.position.x, abs=1e-6) and composed.y == pytest.approx(
            g.position.y, abs=1e-6
        )
        assert math.remainder(composed.theta - yaw(g.orientation), 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
        compared += 1
    assert compared >= STEPS - 5
