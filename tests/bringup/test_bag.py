"""Recordings: a 60 s simulated run written with rosbags reads back complete, in rosbag2's layout."""

import math

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import TransformStamped
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import Odometry
from PIL import Image
from rclpy.serialization import serialize_message
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from amr_bringup.bag_reader import read_bag, render_bag
from amr_bringup.bag_writer import BagError, BagWriter, TopicQos
from amr_interfaces.msg import SimulatorStatus
from amr_maps.world import load_world, resolve_world_path
from amr_simulation.simulator import Simulator

STEPS = 1200  # 60 s at dt = 0.05
TOPICS = {
    "/scan": ("sensor_msgs/msg/LaserScan", TopicQos(reliable=False, depth=5)),
    "/ground_truth": ("nav_msgs/msg/Odometry", TopicQos(depth=None)),  # history as discovery reports it
    "/tf": ("tf2_msgs/msg/TFMessage", TopicQos(depth=100)),
    "/simulator/status": ("amr_interfaces/msg/SimulatorStatus", TopicQos(transient_local=True, depth=1)),
}


def observation(sim):
    stamp_ns = round(sim.time * 1e9)
    scan = LaserScan(
        angle_min=sim.lidar.angle_min,
        angle_increment=sim.lidar.angle_increment,
        range_min=sim.lidar.range_min,
        range_max=sim.lidar.range_max,
        ranges=sim.ranges.tolist(),
    )
    scan.header.frame_id = "base_scan"
    odom = Odometry(child_frame_id="base_footprint")
    odom.header.frame_id = "odom"
    odom.pose.pose.position.x, odom.pose.pose.position.y = sim.pose.x, sim.pose.y
    odom.pose.pose.orientation.z, odom.pose.pose.orientation.w = (
        math.sin(sim.pose.theta / 2),
        math.cos(sim.pose.theta / 2),
    )
    odom.twist.twist.linear.x = sim.twist[0]
    transform = TransformStamped(child_frame_id="base_footprint")
    transform.header.frame_id = "odom"
    transform.transform.translation.x = sim.odom_pose.x
    for message in (scan, odom, transform):
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    status = SimulatorStatus(collisions=sim.collisions, goal_reached=sim.goal_reached)
    return stamp_ns, {
        "/scan": scan,
        "/ground_truth": odom,
        "/tf": TFMessage(transforms=[transform]),
        "/simulator/status": status,
    }


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A 60 s bump-and-turn drive in the inner maze, every observation recorded."""
    sim = Simulator(load_world(resolve_world_path("inner_maze.yaml")))
    path = tmp_path_factory.mktemp("bags") / "run.mcap"
    sent = []
    with BagWriter(path) as writer:
        for topic, (msgtype, qos) in TOPICS.items():
            writer.add_topic(topic, msgtype, qos)
        for step in range(STEPS):
            sim.step(0.2, 0.0) if (step // 30) % 2 == 0 else sim.step(0.05, 1.5)
            stamp, messages = observation(sim)
            for topic, message in messages.items():
                writer.write(topic, stamp, serialize_message(message))
            sent.append((stamp, messages))
    return path.with_suffix(""), sent, sim


def test_every_message_reads_back(recorded):
    bag, sent, _ = recorded
    recording = read_bag(bag)
    assert {t: recording.count(t) for t in TOPICS} == {t: STEPS for t in TOPICS}
    assert recording.types == {t: msgtype for t, (msgtype, _) in TOPICS.items()}
    for (stamp, messages), (scan_stamp, scan), (_, odom), (_, tf), (_, status) in zip(
        sent, *(recording.topics[t] for t in TOPICS), strict=True
    ):
        assert scan_stamp == stamp
        assert np.array_equal(np.asarray(scan.ranges), np.asarray(messages["/scan"].ranges, dtype=np.float32))
        assert odom.pose.pose.position.x == messages["/ground_truth"].pose.pose.position.x
        assert tf.transforms[0].header.frame_id == "odom" and tf.transforms[0].child_frame_id == "base_footprint"
        assert status.collisions == messages["/simulator/status"].collisions


def test_the_metadata_is_what_rosbag2_reads(recorded):
    bag, _, _ = recorded
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert info["message_count"] == STEPS * len(TOPICS)
    assert all((bag / name).is_file() for name in info["relative_file_paths"])
    assert info["duration"]["nanoseconds"] == round((STEPS - 1) * 0.05 * 1e9)
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert set(topics) == set(TOPICS)
    scan = topics["/scan"]["topic_metadata"]
    assert scan["type"] == "sensor_msgs/msg/LaserScan" and scan["serialization_format"] == "cdr"
    assert scan["offered_qos_profiles"][0]["reliability"] == "best_effort"
    status = topics["/simulator/status"]["topic_metadata"]["offered_qos_profiles"][0]
    assert status["durability"] == "transient_local" and (status["history"], status["depth"]) == ("keep_last", 1)
    unknown = topics["/ground_truth"]["topic_metadata"]["offered_qos_profiles"][0]
    assert (unknown["history"], unknown["depth"]) == ("unknown", 0)  # what discovery says, as rosbag2 writes it
    assert info["ros_distro"] == "jazzy"
    tf_hash = topics["/tf"]["topic_metadata"]["type_description_hash"]
    assert tf_hash == "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"  # Jazzy's


def test_the_mcap_file_decodes_with_its_own_schemas(recorded):
    """What Foxglove does: the ros2 profile, ros2msg schemas and CDR decoded from the file alone."""
    bag, _, _ = recorded
    with open(next(bag.glob("*.mcap")), "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
        counts = {}
        for _, channel, _, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            assert decoded is not None, channel.topic
        assert counts == {t: STEPS for t in TOPICS}


def test_a_bag_renders_as_the_demo_figure(recorded, tmp_path):
    bag, _, sim = recorded
    png = render_bag(bag, tmp_path / "fig" / "run.png", sim.world)
    pixels = np.asarray(Image.open(png).convert("RGB")).astype(int)
    red = (abs(pixels[..., 0] - 214) < 30) & (pixels[..., 1] < 80) & (pixels[..., 2] < 80)  # scan dots
    assert pixels.shape[0] > 500 and red.sum() > 50


def test_bad_recordings_are_refused(tmp_path, recorded):
    bag, _, _ = recorded
    with pytest.raises(BagError, match="exists already"):
        BagWriter(bag)
    with BagWriter(tmp_path / "new") as writer:
        with pytest.raises(BagError, match="no_such_pkg/msg/Thing"):
            writer.add_topic("/x", "no_such_pkg/msg/Thing")
        with pytest.raises(BagError, match="was not added"):
            writer.write("/y", 0, b"")
        writer.add_topic("/x", "std_msgs/msg/String")
        with pytest.raises(BagError, match="added twice"):
            writer.add_topic("/x", "std_msgs/msg/String")
    with pytest.raises(BagError, match="cannot read"):
        read_bag(tmp_path / "absent")
