"""The wall follower node: synchronized inputs, both output types, stale data, bad config, deactivation."""

import math
import threading

import pytest
from geometry_msgs.msg import Twist, TwistStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from support.ros import spin_for, spin_until

from amr_bringup.lifecycle_manager import LifecycleManager
from amr_control.wall_follower_node import WallFollowerNode
from amr_interfaces.msg import NavigatorStatus, WallFollowerStatus
from amr_turtlebot3.odometry_node import OdometryNode

BEAMS = 240


def corridor_scan(stamp_ns: int, right: float = 0.2, left: float = 0.2, front: float = 3.0) -> LaserScan:
    """A scan inside a straight corridor: walls at `right`/`left` metres, something `front` ahead."""
    scan = LaserScan()
    scan.header.stamp.sec, scan.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    scan.header.frame_id = "base_scan"
    scan.angle_min, scan.angle_increment = 0.0, 2 * math.pi / BEAMS
    scan.angle_max = scan.angle_min + scan.angle_increment * (BEAMS - 1)
    scan.range_min, scan.range_max = 0.12, 3.5
    ranges = []
    for k in range(BEAMS):
        angle = k * scan.angle_increment
        s, c = math.sin(angle), math.cos(angle)
        candidates = [
            front / c if c > 1e-6 else math.inf,
            left / s if s > 1e-6 else math.inf,
            right / -s if s < -1e-6 else math.inf,
        ]
        distance = min(candidates)
        ranges.append(distance if distance <= scan.range_max else math.inf)
    scan.ranges = ranges
    return scan


def odometry(stamp_ns: int, v: float = 0.15) -> Odometry:
    message = Odometry()
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    message.twist.twist.linear.x = v
    return message


class Rig(Node):
    def __init__(self, context, twist_type=TwistStamped):
        super().__init__("rig", context=context)
        self.odometry = self.create_publisher(Odometry, "odometry", 10)
        self.scan = self.create_publisher(LaserScan, "scan", qos_profile_sensor_data)
        self.commands = []
        self.create_subscription(twist_type, "cmd_vel", self.commands.append, 10)
        self.status = []
        self.create_subscription(WallFollowerStatus, "wall_follower/status", self.status.append, 10)

    def send(self, stamp_ns, **scan_kwargs):
        self.odometry.publish(odometry(stamp_ns))
        self.scan.publish(corridor_scan(stamp_ns, **scan_kwargs))


def follower(context, **overrides):
    params = [Parameter(k, value=v) for k, v in overrides.items()]
    return WallFollowerNode(context=context, parameter_overrides=params)


def activate(node):
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)


def active_follower(context, executor, twist_type=TwistStamped, **overrides):
    """An active follower and a rig wired to it, once the follower listens to both inputs."""
    node, rig = follower(context, **overrides), Rig(context, twist_type=twist_type)
    executor.add_node(node)
    executor.add_node(rig)
    activate(node)
    assert spin_until(executor, lambda: rig.scan.get_subscription_count() and rig.odometry.get_subscription_count(), 5)
    return node, rig


def test_simulation_mode_answers_every_pair_with_a_twist_stamped(ros_context, executor):
    node, rig = active_follower(ros_context, executor)
    for k in range(10):
        rig.send(10**9 + k * 50_000_000, right=0.25)  # 5 cm too far from the right wall
        assert spin_until(executor, lambda k=k: len(rig.commands) == k + 1, 5), f"no command for pair {k}"
    last = rig.commands[-1].twist
    assert last.linear.x > 0.0 and last.angular.z < 0.0, "too far from the right wall: turn right (clockwise)"
    assert spin_until(executor, lambda: len(rig.status) == 10, 5)
    assert rig.status[-1].followed_wall == "right" and abs(rig.status[-1].right - 0.25) < 0.02
    assert rig.status[-1].angular == last.angular.z and rig.status[-1].state
    assert all(math.isfinite(c.twist.angular.z) for c in rig.commands)


def test_bad_scans_never_make_nan_commands(ros_context, executor):
    node, rig = active_follower(ros_context, executor)
    bad = [[], [math.nan] * BEAMS, [math.inf] * BEAMS, [1e30] * BEAMS, [0.3] * 3]
    for k, ranges in enumerate(bad):
        stamp = 10**9 + k * 50_000_000
        scan = corridor_scan(stamp)
        scan.ranges = ranges
        rig.odometry.publish(odometry(stamp, v=math.nan))
        rig.scan.publish(scan)
        assert spin_until(executor, lambda k=k: len(rig.commands) == k + 1, 5)
    for command in rig.commands:
        assert math.isfinite(command.twist.linear.x) and math.isfinite(command.twist.angular.z)
    assert node.state_label == "active"


def test_real_robot_mode_uses_twist_a_timer_and_stops_on_stale_data(ros_context, executor):
    node, rig = active_follower(
        ros_context, executor, Twist, simulation=False, sync_slop=0.15, flip_angular_sign=True, stale_timeout=0.1
    )
    now = node.get_clock().now().nanoseconds
    for k in range(6):  # the real robot: odometry and scan stamps differ a little
        rig.odometry.publish(odometry(now + k * 50_000_000 + 7_000_000))
        rig.scan.publish(corridor_scan(now + k * 50_000_000, right=0.25))
        spin_for(executor, 0.05)
    moving = [c for c in rig.commands if c.linear.x > 0.0]
    assert moving, "the timer never published a command from the stored pair"
    assert moving[-1].angular.z > 0.0, "flip_angular_sign must invert the clockwise turn"
    rig.commands.clear()
    spin_for(executor, 0.5)  # no more data: stale
    assert rig.commands and rig.commands[-1].linear.x == 0.0 and rig.commands[-1].angular.z == 0.0


def navigator_status(stamp_ns: int, controller: str) -> NavigatorStatus:
    status = NavigatorStatus(controller=controller, mode="EXPLORE" if controller == "wall_follower" else "FOLLOW")
    status.header.stamp.sec, status.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    return status


def test_navigated_answers_only_what_the_navigator_gives_it_and_a_held_observation_on_a_new_decision(
    ros_context, executor
):
    node, rig = active_follower(ros_context, executor, navigated=True)
    status = rig.create_publisher(NavigatorStatus, "navigator/status", 10)
    assert spin_until(executor, lambda: status.get_subscription_count() > 0, 5)
    assert not any(
        topic == "/cmd_vel" for topic, _ in node.get_subscriber_names_and_types_by_node("wall_follower", "/")
    )
    for k, controller in enumerate(["wall_follower", "wall_follower", "path_follower", ""]):
        stamp = 10**9 + k * 50_000_000
        rig.send(stamp)
        status.publish(navigator_status(stamp, controller))
        spin_for(executor, 0.2)
    assert len(rig.commands) == 2, "answered exactly the two observations the navigator gave it"
    status.publish(navigator_status(10**9 + 3 * 50_000_000, "wall_follower"))  # a new decision, held observation 3
    assert spin_until(executor, lambda: len(rig.commands) == 3, 5)
    status.publish(navigator_status(10**9 + 2 * 50_000_000, "wall_follower"))  # observation 2 was answered already
    spin_for(executor, 0.3)
    assert len(rig.commands) == 3


def test_navigated_real_robot_stops_once_when_the_navigator_hands_over_then_stays_silent(ros_context, executor):
    node, rig = active_follower(ros_context, executor, Twist, simulation=False, sync_slop=0.15, navigated=True)
    status = rig.create_publisher(NavigatorStatus, "navigator/status", 10)
    assert spin_until(executor, lambda: status.get_subscription_count() > 0, 5)
    spin_for(executor, 0.3)
    assert rig.commands == [], "not given any observation yet: no stale-data zeros either"
    now = node.get_clock().now().nanoseconds
    for k in range(6):
        stamp = now + k * 50_000_000
        rig.send(stamp, right=0.25)
        status.publish(navigator_status(stamp, "wall_follower"))
        spin_for(executor, 0.05)
    assert any(c.linear.x > 0.0 for c in rig.commands), "in charge: the timer drives"
    rig.commands.clear()
    for k in range(6, 12):
        stamp = now + k * 50_000_000
        rig.send(stamp, right=0.25)
        status.publish(navigator_status(stamp, "path_follower"))
        spin_for(executor, 0.05)
    spin_for(executor, 0.5)
    # the last command is the hand-over's zero, then silence; a tick before it may hold the last command, or stop on
    # data gone stale while a loaded machine delayed the observations (a real robot's follower stops then too)
    assert rig.commands and rig.commands[-1].linear.x == 0.0 and rig.commands[-1].angular.z == 0.0, rig.commands
    assert len(rig.commands) <= 2, "one zero at the hand-over, then silence"


def test_deactivation_publishes_a_zero_command(ros_context, executor):
    node, rig = active_follower(ros_context, executor)
    rig.send(10**9)
    assert spin_until(executor, lambda: len(rig.commands) == 1, 5)
    assert node.try_transition(Transition.TRANSITION_DEACTIVATE)
    assert spin_until(executor, lambda: len(rig.commands) == 2, 5)
    assert rig.commands[-1].twist.linear.x == 0.0 and rig.commands[-1].twist.angular.z == 0.0
    rig.send(2 * 10**9)
    spin_for(executor, 0.3)
    assert len(rig.commands) == 2, "an inactive follower must stay quiet"


@pytest.mark.parametrize(
    ("override", "key"), [({"kp": "fast"}, "kp"), ({"preferred_wall": "up"}, "preferred_wall"), ({"dt": -0.05}, "dt")]
)
def test_bad_parameters_fail_configure_naming_the_key(ros_context, executor, override, key):
    node = follower(ros_context, **override)
    executor.add_node(node)
    assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.state_label == "unconfigured"
    assert node.configure_error.startswith(key)


def test_manager_brings_the_stack_up_in_order_and_down_in_reverse(ros_context, multi_executor):
    odometry_node, follower_node = OdometryNode(context=ros_context), follower(ros_context)
    manager = LifecycleManager(
        context=ros_context,
        parameter_overrides=[
            Parameter("node_startup_order", value=["odometry_node", "wall_follower"]),
            Parameter("wait_timeout", value=5.0),
        ],
    )
    for node in (odometry_node, follower_node, manager):
        multi_executor.add_node(node)
    spinner = threading.Thread(target=multi_executor.spin, daemon=True)
    spinner.start()
    steps = manager.startup()
    assert manager.started, steps
    assert [(s.node, s.transition) for s in steps] == [
        ("odometry_node", "configure"),
        ("odometry_node", "activate"),
        ("wall_follower", "configure"),
        ("wall_follower", "activate"),
    ]
    assert odometry_node.state_label == follower_node.state_label == "active"
    steps = manager.shutdown()
    assert [s.node for s in steps] == ["wall_follower", "wall_follower", "odometry_node", "odometry_node"]
    assert odometry_node.state_label == follower_node.state_label == "unconfigured"


def test_manager_stops_at_a_node_that_fails_configure(ros_context, multi_executor):
    bad = follower(ros_context, kp="fast")
    odometry_node = OdometryNode(context=ros_context)
    manager = LifecycleManager(
        context=ros_context,
        parameter_overrides=[
            Parameter("node_startup_order", value=["wall_follower", "odometry_node"]),
            Parameter("wait_timeout", value=5.0),
        ],
    )
    for node in (bad, odometry_node, manager):
        multi_executor.add_node(node)
    threading.Thread(target=multi_executor.spin, daemon=True).start()
    steps = manager.startup()
    assert not manager.started and steps[-1].node == "wall_follower" and steps[-1].transition == "configure"
    assert odometry_node.state_label == "unconfigured", "the sequence must stop at the failure"


def test_real_robot_mode_holds_the_last_command_between_slow_scans(ros_context, executor):
    """The LDS-01 scans at 5 Hz, the controller runs at 20 Hz: between pairs the command is held, not zeroed."""
    node, rig = active_follower(ros_context, executor, Twist, simulation=False, sync_slop=0.15, stale_timeout=0.5)
    now = node.get_clock().now().nanoseconds
    for k in range(5):
        rig.send(now + k * 200_000_000, right=0.25)
        spin_for(executor, 0.2)
    moving = [c for c in rig.commands if c.linear.x > 0.0]
    assert len(moving) >= 10, "between 5 Hz scans the 20 Hz timer must repeat the last command"
    first_moving = rig.commands.index(moving[0])
    assert all(c.linear.x > 0.0 for c in rig.commands[first_moving:]), "no zero command while data is fresh"


def test_a_live_gain_set_changes_the_next_command_and_structure_stays(ros_context, executor):
    node, rig = active_follower(ros_context, executor)
    for k in range(1, 30):  # settle into following the right wall of a straight corridor
        rig.send(k * 50_000_000)
        assert spin_until(executor, lambda k=k: len(rig.commands) == k, 5)
    assert rig.commands[-1].twist.linear.x == pytest.approx(0.15)
    results = node.set_parameters([Parameter("linear_speed", value=0.08)])
    assert results[0].successful, results[0].reason
    rig.send(30 * 50_000_000)
    assert spin_until(executor, lambda: len(rig.commands) == 30, 5)
    assert rig.commands[-1].twist.linear.x == pytest.approx(0.08), "the next step uses the new speed"
    refused = {
        "dt": (0.1, "dt is read-only while configured; cleanup, set, configure"),
        "kp": ("abc", "Wrong parameter type"),
        "preferred_wall": ("up", "preferred_wall: must be one of right, left, random"),
        "target_wall_distance": (0.5, "wall_lost_distance (0.4) must exceed target_wall_distance (0.5)"),
    }
    for name, (value, reason) in refused.items():
        result = node.set_parameters([Parameter(name, value=value)])[0]
        assert not result.successful and reason in result.reason, (name, result.reason)
    assert node.config.target_wall_distance == 0.2 and node.get_parameter("target_wall_distance").value == 0.2


def test_a_stamp_far_in_the_future_does_not_stop_the_robot_forever(ros_context, executor):
    node, rig = active_follower(ros_context, executor)
    for k in range(1, 4):
        rig.send(k * 50_000_000)
        assert spin_until(executor, lambda k=k: len(rig.commands) == k, 5)
    rig.send(10**15)  # one pair stamped 1e6 s ahead: answered, it is a pair like any other
    assert spin_until(executor, lambda: len(rig.commands) == 4, 5)
    for k in range(4, 10):  # normal stamps again: a clock jump back, recovered from with a warning
        rig.send(k * 50_000_000)
        assert spin_until(executor, lambda k=k: len(rig.commands) == k + 1, 5), "commands must resume"
    assert node._sync.stats.clock_jumps == 1
    bad = odometry(10 * 50_000_000)
    bad.header.stamp.nanosec = 2_000_000_000  # out of [0, 1e9): malformed, dropped with a warning
    rig.odometry.publish(bad)
    rig.scan.publish(corridor_scan(10 * 50_000_000))
    spin_for(executor, 0.3)
    assert len(rig.commands) == 10
    rig.send(11 * 50_000_000)
    assert spin_until(executor, lambda: len(rig.commands) == 11, 5)
