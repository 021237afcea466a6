"""The simulator node running a world that lists its robots: namespaced topics, TF both ways,
lockstep over every robot, per-robot and world-wide services."""

import pytest
from lifecycle_msgs.msg import Transition
from rclpy.node import Node
from std_srvs.srv import Trigger
from support.ros import published_topics, spin_until
from support.simulator_probe import RELIABLE, TIMEOUT, call, seconds, settle
from tf2_msgs.msg import TFMessage

from amr_interfaces.srv import SetPose
from amr_util.qos import LATCHED

DT = 0.05
RADIUS = 0.105
# two robots facing each other along y = 0 in a 4 m x 3 m room, 2 m apart; each one's goal behind the other
TWO = """\
name: two_facing
wall_thickness: 0.05
walls:
  - [-2.0, -1.5, 2.0, -1.5]
  - [2.0, -1.5, 2.0, 1.5]
  - [2.0, 1.5, -2.0, 1.5]
  - [-2.0, 1.5, -2.0, -1.5]
robots:
  - name: r1
    start: [-1.0, 0.0, 0.0]
    goal: [1.6, 1.1, 0.15]
  - name: r2
    start: [1.0, 0.0, 3.14159265358979]
"""


@pytest.fixture
def two_world(tmp_path):
    path = tmp_path / "two_facing.yaml"
    path.write_text(TWO)
    return str(path)


class TfProbe(Node):
    """Records every TFMessage on the given topics (latched ones with transient local)."""

    def __init__(self, context, topics: dict[str, bool]) -> None:
        super().__init__("tf_probe", context=context)
        self.messages: dict[str, list[TFMessage]] = {topic: [] for topic in topics}
        self.subscriptions_ = [
            self.create_subscription(TFMessage, topic, self.messages[topic].append, LATCHED if latched else RELIABLE)
            for topic, latched in topics.items()
        ]

    def frames(self, topic: str) -> set[tuple[str, str]]:
        return {(t.header.frame_id, t.child_frame_id) for m in self.messages[topic] for t in m.transforms}


def start_fleet(executor, node, probes, extra=()) -> None:
    for each in (node, *probes, *extra):
        executor.add_node(each)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE), "configure failed"
    assert spin_until(executor, lambda: all(p.connected() for p in probes), TIMEOUT)
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: all(p.observations() >= 1 for p in probes), TIMEOUT), "no first observation"


def drive_all(executor, probes, commands) -> None:
    """Lockstep for a fleet: every robot sends its command, then every robot's observation comes back."""
    for step in commands:
        counts = [p.observations() for p in probes]
        for p, (v, w) in zip(probes, step, strict=True):
            p.send(v, w)
        assert spin_until(
            executor,
            lambda counts=counts: all(p.observations() > c for p, c in zip(probes, counts, strict=True)),
            TIMEOUT,
        ), "not every robot's observation came back"


def topics_of(node, expected) -> dict[str, str]:
    return published_topics(node, node.get_name(), node.get_namespace(), expected)


def test_every_topic_is_in_its_robots_namespace_and_the_world_steps_when_every_robot_has_answered(
    simulator, probe, executor, two_world
):
    node = simulator(world=two_world, **{"lidar.noise_std": 0.0})
    r1, r2 = probe(robot="r1"), probe(robot="r2")
    start_fleet(executor, node, [r1, r2])
    published = topics_of(
        node, [f"/{r}/{t}" for r in ("r1", "r2") for t in ("scan", "odom", "odometry", "ground_truth", "status")]
    )
    for robot in ("r1", "r2"):
        for topic in ("scan", "odom", "odometry", "ground_truth", "status", "tf", "tf_static"):
            assert f"/{robot}/{topic}" in published, (robot, topic, sorted(published))
    assert "/r1/goal" in published and "/r2/goal" not in published, "only r1 has a goal"
    assert "/clock" in published
    for plain in ("/scan", "/odom", "/odometry", "/tf", "/tf_static", "/simulator/status"):
        assert plain not in published, f"{plain}: a fleet's topics are namespaced"
    services = {name for name, _ in node.get_service_names_and_types_by_node(node.get_name(), node.get_namespace())}
    assert {
        "/r1/set_pose",
        "/r1/reset",
        "/r2/set_pose",
        "/r2/reset",
        "/simulator/reset",
        "/simulator/pause",
        "/simulator/step",
    } <= services
    assert "/simulator/set_pose" not in services, "set_pose is per robot in a fleet"

    assert [s.robot for s in r1.statuses] == ["r1"] and [s.robot for s in r2.statuses] == ["r2"]
    # each sees the other ahead: 2 m between centres, the LiDAR 3.2 cm behind the axle, the other's disc 0.105 m
    for p in (r1, r2):
        assert p.scans[-1].ranges[0] == pytest.approx(2.0 + 0.032 - RADIUS, abs=1e-3)
        assert p.scans[-1].header.frame_id == "base_scan"
        assert (p.odometry[-1].header.frame_id, p.odometry[-1].child_frame_id) == ("odom", "base_footprint")

    # r1 alone: the world waits for r2
    r1.send(0.2)
    settle(executor, 0.5)
    assert (r1.observations(), r2.observations()) == (1, 1), "one robot's command alone must not step the world"
    r2.send(0.1)
    assert spin_until(executor, lambda: r1.observations() == 2 and r2.observations() == 2, TIMEOUT)
    assert r1.statuses[-1].steps == r2.statuses[-1].steps == 1
    assert seconds(r1.scans[-1].header.stamp) == seconds(r2.scans[-1].header.stamp) == pytest.approx(DT)
    assert r1.ground_truth[-1].pose.pose.position.x == pytest.approx(-1.0 + 0.2 * DT, abs=1e-9)
    assert r2.ground_truth[-1].pose.pose.position.x == pytest.approx(1.0 - 0.1 * DT, abs=1e-6)

    # toward each other until they touch: one robot collision each, both stopped apart
    drive_all(executor, [r1, r2], [((0.2, 0.0), (0.2, 0.0))] * 100)
    settle(executor)
    # one observation per robot and step, no more (an observation resent after lockstep_resend_period, on a loaded
    # machine, carries its step's stamp again: it is not another step)
    steps = [len({(m.header.stamp.sec, m.header.stamp.nanosec) for m in p.scans}) for p in (r1, r2)]
    assert steps == [102, 102], steps
    gap = r2.ground_truth[-1].pose.pose.position.x - r1.ground_truth[-1].pose.pose.position.x
    assert gap == pytest.approx(2 * RADIUS, abs=0.02)
    for p in (r1, r2):
        assert (p.statuses[-1].robot_collisions, p.statuses[-1].wall_collisions, p.statuses[-1].collisions) == (1, 0, 1)
        assert p.statuses[-1].in_contact
        assert min(p.scans[-1].ranges) < 2 * RADIUS, "the other robot fills its scan"


def test_tf_per_namespace_with_plain_frames(simulator, probe, executor, two_world):
    node = simulator(world=two_world, publish_map_to_odom=True)
    r1, r2 = probe(robot="r1"), probe(robot="r2")
    tf = TfProbe(
        node.context,
        {
            "/r1/tf": False,
            "/r2/tf": False,
            "/r1/tf_static": True,
            "/r2/tf_static": True,
            "/tf": False,
            "/tf_static": True,
        },
    )
    start_fleet(executor, node, [r1, r2], [tf])
    drive_all(executor, [r1, r2], [((0.1, 0.0), (0.0, 0.5))] * 3)
    assert spin_until(executor, lambda: all(len(tf.messages[f"/{r}/tf"]) >= 4 for r in ("r1", "r2")), TIMEOUT)
    assert spin_until(executor, lambda: tf.messages["/r1/tf_static"] and tf.messages["/r2/tf_static"], TIMEOUT)
    for robot in ("r1", "r2"):
        assert tf.frames(f"/{robot}/tf") == {("odom", "base_footprint"), ("map", "odom")}
        assert tf.frames(f"/{robot}/tf_static") == {("base_footprint", "base_scan")}
    assert not tf.messages["/tf"] and not tf.messages["/tf_static"], "nothing on the shared tree"
    # r1's tree is r1's: its odom -> base follows r1's odometry, not r2's
    last = tf.messages["/r1/tf"][-1].transforms[0]
    assert last.transform.translation.x == pytest.approx(r1.odometry[-1].pose.pose.position.x)


def test_one_tf_tree_prefixes_every_frame_but_the_world(simulator, probe, executor, two_world):
    node = simulator(world=two_world, one_tf_tree=True, publish_map_to_odom=True)
    r1, r2 = probe(robot="r1"), probe(robot="r2")
    tf = TfProbe(node.context, {"/tf": False, "/tf_static": True, "/r1/tf": False})
    start_fleet(executor, node, [r1, r2], [tf])
    drive_all(executor, [r1, r2], [((0.1, 0.0), (0.1, 0.0))] * 2)
    assert spin_until(executor, lambda: len(tf.messages["/tf"]) >= 3 and tf.messages["/tf_static"], TIMEOUT)
    assert tf.frames("/tf") == {
        ("r1/odom", "r1/base_footprint"),
        ("map", "r1/odom"),
        ("r2/odom", "r2/base_footprint"),
        ("map", "r2/odom"),
    }
    assert all(len(m.transforms) == 4 for m in tf.messages["/tf"]), "one TFMessage per step for the fleet"
    # latched: the last message holds both mountings
    assert tf.frames("/tf_static") == {("r1/base_footprint", "r1/base_scan"), ("r2/base_footprint", "r2/base_scan")}
    assert not tf.messages["/r1/tf"]
    assert (r2.odometry[-1].header.frame_id, r2.odometry[-1].child_frame_id) == ("r2/odom", "r2/base_footprint")
    assert r2.scans[-1].header.frame_id == "r2/base_scan"
    assert r2.ground_truth[-1].header.frame_id == "map"


def test_per_robot_and_world_services(simulator, probe, executor, two_world):
    node = simulator(world=two_world)
    r1, r2 = probe(robot="r1"), probe(robot="r2")
    start_fleet(executor, node, [r1, r2])
    drive_all(executor, [r1, r2], [((0.2, 0.0), (0.0, 1.0))] * 10)

    # teleport r2: only r2's observation goes out, one dt on; r1 stays where it was
    counts = (r1.observations(), r2.observations())
    answer = call(executor, r2.set_pose, SetPose.Request(x=1.0, y=1.0, theta=0.5))
    assert answer.success, answer.message
    assert spin_until(executor, lambda: r2.observations() == counts[1] + 1, TIMEOUT)
    settle(executor)
    assert r1.observations() == counts[0]
    assert (r2.ground_truth[-1].pose.pose.position.x, r2.ground_truth[-1].pose.pose.position.y) == (1.0, 1.0)
    assert seconds(r2.scans[-1].header.stamp) == pytest.approx(11 * DT)
    # onto the other robot: refused, naming it
    x1 = r1.ground_truth[-1].pose.pose.position.x
    answer = call(executor, r2.set_pose, SetPose.Request(x=x1 + 0.1, y=0.0, theta=0.0))
    assert not answer.success and "r1" in answer.message and answer.message.startswith("r2: ")

    # the loop goes on after a teleport: r1's held command waits for r2's answer to its new observation
    drive_all(executor, [r1, r2], [((0.0, 0.0), (0.0, 0.0))])
    assert seconds(r1.scans[-1].header.stamp) == seconds(r2.scans[-1].header.stamp) == pytest.approx(12 * DT)

    # reset r1 alone: back to its start, its counters cleared; the world's time goes on
    answer = call(executor, r1.reset, Trigger.Request())
    assert answer.success, answer.message
    assert spin_until(executor, lambda: r1.ground_truth[-1].pose.pose.position.x == -1.0, TIMEOUT)
    assert r1.statuses[-1].distance_travelled == 0.0
    assert r1.statuses[-1].steps == 11

    # reset the world: both back, time 0, stamps on
    world_reset = node.create_client(Trigger, "/simulator/reset")
    counts = (r1.observations(), r2.observations())
    assert call(executor, world_reset, Trigger.Request()).success
    assert spin_until(executor, lambda: r1.observations() > counts[0] and r2.observations() > counts[1], TIMEOUT)
    assert r2.ground_truth[-1].pose.pose.position.x == 1.0 and r1.statuses[-1].steps == r2.statuses[-1].steps == 0
    assert seconds(r1.scans[-1].header.stamp) > 12 * DT, "stamps never go back"


def test_a_silent_controller_holds_the_world_and_gets_its_observation_again(
    simulator, probe, executor, two_world, capfd
):
    node = simulator(world=two_world, lockstep_resend_period=0.3)
    r1, r2 = probe(robot="r1"), probe(robot="r2")
    start_fleet(executor, node, [r1, r2])
    r1.send(0.1)
    # two resend periods after r1's answer (both were resent while the first observations came in under load), r1's
    # count is where it stays: r2 is resent to, r1 is not
    sent = r2.observations()
    assert spin_until(executor, lambda: r2.observations() >= sent + 2, TIMEOUT), "r2's observation is not sent again"
    answered = r1.observations()
    assert spin_until(executor, lambda: r2.observations() >= sent + 4, TIMEOUT), "r2's observation is not resent"
    assert r1.observations() == answered, "r1 has answered: it waits, nothing is resent to it"
    assert r1.statuses[-1].steps == 0 and r2.statuses[-1].steps == 0
    assert "waits for /r2/cmd_vel" in capfd.readouterr().err
    r2.send(0.1)
    assert spin_until(executor, lambda: r1.observations() == answered + 1, TIMEOUT)
    assert r1.statuses[-1].steps == 1


def test_realtime_steps_every_robot_and_stops_a_silent_one(simulator, probe, executor, two_world):
    node = simulator(world=two_world, mode="realtime", rate=2.0, command_timeout=0.2)
    r1, r2 = probe(robot="r1"), probe(robot="r2")
    start_fleet(executor, node, [r1, r2])
    r1.send(0.2)
    r2.send(0.0, 1.0)
    assert spin_until(executor, lambda: r1.observations() >= 20 and r2.observations() >= 20, TIMEOUT)
    # r1 moved 0.2 m/s for command_timeout (+ a step) only, then stopped; r2 turned on the spot
    x = r1.ground_truth[-1].pose.pose.position.x
    assert -1.0 + 0.2 * 0.2 - 1e-9 <= x <= -1.0 + 0.2 * (0.2 + 2 * DT) + 1e-9
    assert r1.ground_truth[-1].twist.twist.linear.x == 0.0
    assert r2.ground_truth[-1].pose.pose.position.x == pytest.approx(1.0, abs=1e-6)
    assert r2.ground_truth[-1].twist.twist.angular.z == 0.0, "r2 stopped too once its command timed out"
    assert r2.statuses[-1].steps >= 19


def test_a_one_robot_world_keeps_its_plain_topics(simulator, probe, executor):
    node, driver = simulator(world="open_room.yaml"), probe()
    executor.add_node(node)
    executor.add_node(driver)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.robot_names == ("",)
    plain = {"/scan", "/odom", "/odometry", "/ground_truth", "/simulator/status", "/tf", "/tf_static", "/clock"}
    published = topics_of(node, plain)
    assert plain <= set(published)
    assert not any(name.count("/") > 1 and not name.startswith("/simulator/") for name in published), published


def test_a_fleet_world_refuses_the_start_override(simulator, executor, two_world, capfd):
    node = simulator(world=two_world, start=[0.0, 0.0, 0.0])
    executor.add_node(node)
    assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert "start: overrides the start of a world of one unnamed robot" in capfd.readouterr().err
    assert node.robot_names == ()


def test_paused_a_step_waits_for_every_robot_and_holds_a_silent_one_at_zero(simulator, probe, executor, two_world):
    node = simulator(world=two_world, lockstep_resend_period=0.3)
    r1, r2 = probe(robot="r1"), probe(robot="r2")
    start_fleet(executor, node, [r1, r2])
    pause, step = (node.create_client(Trigger, f"/simulator/{name}") for name in ("pause", "step"))
    assert call(executor, pause, Trigger.Request()).success  # (the resend timer may have resent the first one)
    settle(executor, 0.1)
    seen = (r1.observations(), r2.observations())
    r1.send(0.2)
    settle(executor, 0.8)
    assert (r1.observations(), r2.observations()) == seen, "paused: nothing steps, nothing is resent"
    answer = call(executor, step, Trigger.Request())
    assert answer.success, answer.message
    # r2 has said nothing for longer than the resend period: the owed step moves r1 and holds r2
    assert spin_until(executor, lambda: r1.ground_truth[-1].header.stamp.nanosec > 0, TIMEOUT)
    assert r1.statuses[-1].steps == 1
    assert r1.ground_truth[-1].pose.pose.position.x == pytest.approx(-1.0 + 0.2 * DT, abs=1e-9)
    assert spin_until(executor, lambda: r2.statuses[-1].steps == 1, TIMEOUT)
    assert r2.ground_truth[-1].pose.pose.position.x == 1.0
    settle(executor, 0.8)
    assert r1.statuses[-1].steps == r2.statuses[-1].steps == 1, "one step owed, one taken"


def test_every_message_of_robot_2_is_what_the_library_state_gives(simulator, probe, executor, two_world):
    """The node keeps its messages serialized and rewrites the changing fields in place (amr_util.wire): what
    arrives must be the message amr_simulation.messages builds from the library's state, field for field."""
    from amr_simulation import messages
    from amr_util.geometry import map_to_odom

    node = simulator(world=two_world, publish_map_to_odom=True)
    r1, r2 = probe(robot="r1"), probe(robot="r2")
    tf = TfProbe(node.context, {"/r2/tf": False})
    start_fleet(executor, node, [r1, r2], [tf])
    drive_all(executor, [r1, r2], [((0.1, 0.3), (0.15, -0.4))] * 6)
    assert spin_until(executor, lambda: len(tf.messages["/r2/tf"]) >= 7, TIMEOUT)
    settle(executor)
    robot, fleet, turn = node._fleet.robots[1], node._fleet, node._control.robots[1]
    stamp = r2.scans[-1].header.stamp
    assert seconds(stamp) == pytest.approx(6 * DT)
    v, w = robot.odom_twist
    assert v != 0.0 and w != 0.0, "the robot moves: the test compares changing fields"
    expected = {
        "odometry": messages.odometry(stamp, "odom", "base_footprint", robot.odom_pose, (v, 0.0, w)),
        "odom": messages.odometry(stamp, "odom", "base_footprint", robot.odom_pose, (0.0, 0.0, 0.0)),
        "ground_truth": messages.odometry(stamp, "map", "base_footprint", robot.pose, robot.twist),
    }
    for name, message in expected.items():
        received = r2.streams()[name][-1]
        assert received.header == message.header and received.child_frame_id == message.child_frame_id, name
        assert received.pose.pose.position.x == pytest.approx(message.pose.pose.position.x, abs=1e-12), name
        assert received.pose == message.pose and received.twist == message.twist, name
    scan = messages.laser_scan(stamp, "base_scan", robot.ranges, fleet.lidar, fleet.config.dt)
    received = r2.scans[-1]
    assert (received.angle_min, received.angle_increment, received.range_max, received.scan_time) == pytest.approx(
        (scan.angle_min, scan.angle_increment, scan.range_max, scan.scan_time)
    )
    assert list(received.ranges) == list(scan.ranges), "the scan is robot 2's own, this step's"
    status = messages.status(stamp, "map", fleet, robot, turn.distance, 0.0)
    got = r2.statuses[-1]
    for name in messages.STATUS_FIELDS:
        if name not in ("real_time_factor", "position_error", "heading_error"):
            assert getattr(got, name) == getattr(status, name), name
    assert got.robot == "r2" and got.header == status.header and got.steps == 6 and got.distance_travelled > 0.0
    transforms = tf.messages["/r2/tf"][-1].transforms
    assert [(t.header.frame_id, t.child_frame_id) for t in transforms] == [("odom", "base_footprint"), ("map", "odom")]
    for transform, pose in zip(transforms, (robot.odom_pose, map_to_odom(robot.pose, robot.odom_pose)), strict=True):
        want = messages.transform(stamp, "", "", pose)
        assert transform.header.stamp == stamp and transform.transform == want.transform
