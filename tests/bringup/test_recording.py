"""Recording a running stack: the recorder node in a composed maze_sim (60 simulated seconds, lockstep), amr-bringup
--record (the recorder as a process of its own), and the standalone `ros2 run amr_bringup recorder`; the bags read
back in order (complete, for the recorder in the stack's process) and render."""

from __future__ import annotations

import time

import numpy as np
import pytest
import yaml
from PIL import Image
from rclpy.parameter import Parameter
from support.bringup_run import Bringup
from support.waiting import poll_until

from amr_bringup import render_bag
from amr_bringup.bag_reader import read_bag
from amr_bringup.composed import composed_stack
from amr_bringup.recorder import BackgroundSpin, Recorder

SPAN = 60.0
DT = 0.05
OBSERVATION = ("/clock", "/tf", "/odometry", "/odom", "/ground_truth", "/scan", "/simulator/status")
"""What the simulator publishes once per observation (activation, then every step)."""


def assert_complete(recording, observation_topics=OBSERVATION) -> int:
    """Every observation of the run is in the bag: steps + 1 of each (the status says how many steps)."""
    steps = recording.topics["/simulator/status"][-1][1].steps
    counts = {topic: recording.count(topic) for topic in observation_topics}
    assert set(counts.values()) == {steps + 1}, f"{steps} steps, counts {counts}"
    return steps


def assert_recorded_in_order(recording, observation_topics) -> int:
    """Each step at most once and in order, every topic recorded. Not that nothing is missing: a recorder process
    starved of CPU can miss a burst anywhere in a lockstep run, as rosbag2's would (scans are best effort, a
    reliable writer keeps its last 10): two test suites at once on a 2-core machine lost bursts of 10-70 steps.
    Nor that the topics end together: DDS orders each topic, not one against another, so a recorder stopped with the
    stack may hold a step's /clock and not yet its status (CI once had /clock for 1,590 steps, the status for 1,589).
    The last step is the latest that either the status or /clock names."""
    steps = [message.steps for _, message in recording.topics["/simulator/status"]]
    assert steps == sorted(set(steps)), steps[:10]
    clock = [
        round((message.clock.sec + message.clock.nanosec * 1e-9) / DT) for _, message in recording.topics["/clock"]
    ]
    assert clock == sorted(set(clock)), clock[:10]
    last = max(steps[-1], clock[-1])
    for topic in observation_topics:
        assert 0 < recording.count(topic) <= last + 1, (topic, recording.count(topic), last)
    return last


def test_a_60_s_maze_run_is_recorded_complete_with_rosbag2_metadata_and_renders(ros_context, tmp_path):
    recorder = Recorder(
        context=ros_context,
        parameter_overrides=[
            Parameter("path", value=str(tmp_path / "run.mcap")),
            Parameter("use_sim_time", value=True),
        ],
    )
    wanted = round(SPAN / DT) + 1
    recording = BackgroundSpin(recorder)  # as amr-bringup --record runs it
    with composed_stack(
        ros_context,
        "maze_sim",
        parameters={"simulator.lockstep_resend_period": "0.0"},
        before_activate=lambda node: recorder.wait_until_caught_up(),
    ) as (_, manager, _):
        assert all(step.ok for step in manager.startup())
        poll_until(lambda: recorder.counts.get("/clock", 0) >= wanted, 300.0, 0.05)  # 8x real time on a quiet machine
        manager.shutdown()
    recording.stop()  # the bag is finished
    counted = dict(recorder.counts)  # what the recorder's subscriptions received

    recording = read_bag(tmp_path / "run")
    steps = assert_complete(recording)
    assert steps * DT >= SPAN
    assert {topic: recording.count(topic) for topic in recording.topics} == counted
    assert recording.count("/map") == recording.count("/tf_static") == 1
    assert steps <= recording.count("/cmd_vel") <= steps + 2  # + the answer to the last one, + the zero at deactivate
    assert recording.count("/wall_follower/status") >= steps

    info = yaml.safe_load((tmp_path / "run" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap" and info["relative_file_paths"] == ["run.mcap"]
    assert info["message_count"] == sum(counted.values())
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert {name: t["message_count"] for name, t in topics.items()} == counted
    qos = {name: t["topic_metadata"]["offered_qos_profiles"][0] for name, t in topics.items()}
    assert qos["/scan"]["reliability"] == "best_effort" and qos["/odometry"]["reliability"] == "reliable"
    assert qos["/map"]["durability"] == qos["/tf_static"]["durability"] == "transient_local"
    # what discovery offers: DDS does not carry history, so it is unknown with depth 0, as rosbag2 records it
    assert {(q["history"], q["depth"]) for q in qos.values()} == {("unknown", 0)}
    assert info["ros_distro"] == "jazzy"
    assert topics["/tf"]["topic_metadata"]["type"] == "tf2_msgs/msg/TFMessage"
    # stamped on /clock: the bag spans the simulated run, not the wall-clock seconds it took
    assert info["duration"]["nanoseconds"] == pytest.approx(steps * DT * 1e9, abs=2 * DT * 1e9)

    png = tmp_path / "run.png"
    assert render_bag.main([str(tmp_path / "run"), str(png)]) == 0  # walls from the bag's own /map
    with Image.open(png) as image:
        assert image.size[0] > 400 and len(np.unique(np.asarray(image.convert("L")))) > 10


def test_amr_bringup_records_the_named_topics_and_a_standalone_recorder_records_alongside(tmp_path, node_process):
    standalone = node_process(
        "amr_bringup", "recorder", "-p", f"path:={tmp_path / 'map.mcap'}", "-p", "topics:=[/map, /tf_static]"
    )
    topics = ["/clock", "/scan", "/tf", "/simulator/status"]
    run = Bringup(
        "maze_sim", "--composed", "--duration", "5", "--record", str(tmp_path / "run.mcap"), "--topics", *topics
    )
    assert run.finish(timeout=60.0) == 0, run.output
    assert "recorder --ros-args -r __node:=recorder_maze_sim" in run.output, "--record runs the recorder as a process"
    code, output = standalone.stop()
    assert code == 0, output

    recording = read_bag(tmp_path / "run")
    assert sorted(recording.topics) == sorted(topics)
    assert assert_recorded_in_order(recording, topics) > 10, "the stack ran"
    latched = read_bag(tmp_path / "map")  # joined whenever it did: /map and /tf_static are latched
    assert latched.count("/map") == latched.count("/tf_static") == 1
    assert Bringup("maze_sim", "--record", str(tmp_path / "run.mcap")).finish() == 2, "never overwrites a bag"


def test_a_startup_waits_until_the_nodes_publishers_have_matched_the_recorders_subscriptions(ros_context):
    from rclpy.node import Node
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String

    from amr_bringup.recording import wait_until_matched

    talker, listener = Node("talker", context=ros_context), Node("listener", context=ros_context)
    try:
        best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
        talker.create_publisher(String, "/chatter", best_effort)
        talker.create_publisher(String, "/other", 10)
        listener.create_subscription(String, "/chatter", lambda message: None, best_effort)
        listener.create_subscription(String, "/other", lambda message: None, 10)
        listener.create_subscription(String, "/other", lambda message: None, 10)
        assert wait_until_matched(talker, ["/chatter", "/other"], timeout=5.0) == []
        # a reliable reader a best-effort writer never matches: named after the timeout, not waited on for ever
        reliable_only = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        listener.create_subscription(String, "/chatter", lambda message: None, reliable_only)
        started = time.monotonic()
        assert wait_until_matched(talker, ["/chatter"], timeout=0.5) == ["/chatter"]
        assert 0.5 <= time.monotonic() - started < 3.0
        assert wait_until_matched(talker, [], timeout=5.0) == ["/chatter"], "every recorded topic when none is named"
    finally:
        talker.destroy_node()
        listener.destroy_node()
