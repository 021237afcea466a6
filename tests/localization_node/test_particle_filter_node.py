"""The particle_filter node: in a composed lockstep run with the simulator and the wall follower
(localizes, one /pose per scan, throttled cloud, map -> odom, the follower's handover), and alone
against a rig that feeds it bad input, re-seeds it and spreads it again."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped, TwistStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty
from support.localizer_driver import Driver
from support.ros import spin_for, spin_until
from tf2_msgs.msg import TFMessage

from amr_control.wall_follower_node import WallFollowerNode
from amr_interfaces.msg import BeaconRanges, LocalizedPose, LocalizerStatus, SimulatorStatus
from amr_localization.messages import odometry_pose
from amr_localization.particle_filter_node import ParticleFilterNode
from amr_maps.world import load_world
from amr_navigation.navigator_node import NavigatorNode
from amr_simulation import messages as sim_messages
from amr_simulation.simulator import Simulator
from amr_simulation.simulator_node import SimulatorNode
from amr_util.geometry import Pose2D, compose, wrap_angle, yaw_from_quaternion
from amr_util.share import share_directory
from amr_util.stamps import stamp_from_seconds, stamp_nanoseconds

WORLDS = share_directory("amr_maps") / "config" / "worlds"
PARTICLES = 3000
CLOUD_PERIOD = 0.25
STEPS_AFTER_HANDOVER = 10


def configure_and_activate(*nodes) -> None:
    for node in nodes:
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.get_name()
        assert node.try_transition(Transition.TRANSITION_ACTIVATE), node.get_name()


class LoggedWarnings:
    """Records what a node logs at warning level and above (and still logs it)."""

    def __init__(self, node: Node) -> None:
        self.lines: list[str] = []
        self._logger = node._logger
        node._logger = self

    def __getattr__(self, name):
        return getattr(self._logger, name)

    def warning(self, message, **kwargs):
        self.lines.append(message)
        return self._logger.warning(message, **kwargs)

    warn = warning

    def error(self, message, **kwargs):
        self.lines.append(message)
        return self._logger.error(message, **kwargs)


class Recorder(Node):
    """Everything the stack publishes, and a stand-in path follower: a zero command answers every
    observation whose /pose says localized (the navigator, without a goal, gives those to nobody)."""

    def __init__(self, context) -> None:
        super().__init__("recorder", context=context)
        self.poses: list[LocalizedPose] = []
        self.scans: list[int] = []
        self.truth: dict[int, Odometry] = {}
        self.odometry: dict[int, Odometry] = {}
        self.clouds: list[PoseArray] = []
        self.transforms: list[TFMessage] = []
        self.status: list[LocalizerStatus] = []
        self.sim_status: SimulatorStatus | None = None
        self.commands = 0
        self.path_follower_commands = 0
        self.cmd_vel = self.create_publisher(TwistStamped, "cmd_vel", 10)
        self.create_subscription(LocalizedPose, "pose", self._on_pose, 100)
        self.create_subscription(LaserScan, "scan", lambda m: self.scans.append(stamp_ns(m)), qos_profile_sensor_data)
        self.create_subscription(Odometry, "ground_truth", lambda m: self.truth.__setitem__(stamp_ns(m), m), 100)
        self.create_subscription(Odometry, "odometry", lambda m: self.odometry.__setitem__(stamp_ns(m), m), 100)
        self.create_subscription(PoseArray, "particle_cloud", self.clouds.append, 100)
        self.create_subscription(TFMessage, "/tf", self.transforms.append, 100)
        self.create_subscription(LocalizerStatus, "particle_filter/status", self.status.append, 100)
        self.create_subscription(SimulatorStatus, "simulator/status", self._on_sim_status, 100)
        self.create_subscription(TwistStamped, "cmd_vel", self._on_command, 100)

    def _on_pose(self, message: LocalizedPose) -> None:
        self.poses.append(message)
        if message.localized and self.path_follower_commands < STEPS_AFTER_HANDOVER:
            self.path_follower_commands += 1
            self.cmd_vel.publish(TwistStamped())

    def _on_sim_status(self, message: SimulatorStatus) -> None:
        self.sim_status = message

    def _on_command(self, message: TwistStamped) -> None:
        self.commands += 1


def assert_finite(poses) -> None:
    for pose in poses:
        values = [
            pose.pose.pose.position.x,
            pose.pose.pose.position.y,
            pose.pose.pose.orientation.z,
            pose.pose.pose.orientation.w,
            *pose.pose.covariance,
        ]
        assert np.isfinite(values).all()


def stamp_ns(message) -> int:
    return stamp_nanoseconds(message.header.stamp)


def test_localizes_in_a_composed_lockstep_run_and_the_follower_hands_over(executor):
    """inner_maze (the seed maze): global localization while wall following; one /pose per scan, one
    /cmd_vel per observation (the follower's while the navigator gives it the observations, until localized;
    then the stand-in path follower's)."""
    context = executor.context
    simulator = SimulatorNode(
        context=context,
        parameter_overrides=[
            Parameter("world", value="inner_maze.yaml"),
            Parameter("lidar.x", value=-0.032),
            Parameter("lockstep_resend_period", value=0.0),
            Parameter("enable_localization", value=True),
        ],
    )
    follower = WallFollowerNode(
        context=context, parameter_overrides=[Parameter("navigated", value=True), Parameter("lidar_x", value=-0.032)]
    )
    navigator = NavigatorNode(context=context)  # no goal: explore until localized, then nobody drives
    localizer = ParticleFilterNode(
        context=context,
        parameter_overrides=[
            Parameter("world", value="inner_maze.yaml"),
            Parameter("lidar_x", value=-0.032),
            Parameter("max_particles", value=PARTICLES),
            Parameter("particle_cloud_period", value=CLOUD_PERIOD),
        ],
    )
    recorder = Recorder(context)
    for node in (simulator, follower, navigator, localizer, recorder):
        executor.add_node(node)
    configure_and_activate(localizer, follower, navigator)
    spin_until(executor, lambda: simulator.count_subscribers("scan") >= 3, 5.0)  # recorder, filter, follower
    configure_and_activate(simulator)

    def done() -> bool:
        return recorder.path_follower_commands >= STEPS_AFTER_HANDOVER and len(recorder.poses) == len(recorder.scans)

    assert spin_until(executor, done, 90.0), (
        f"not localized: {len(recorder.poses)} poses, {len(recorder.scans)} scans, sim status {recorder.sim_status}"
    )
    spin_for(executor, 0.3)  # a step that would wrongly follow would show up now

    poses, scans = recorder.poses, recorder.scans
    assert [stamp_ns(p) for p in poses] == scans, "one /pose per scan, stamped with the scan's stamp"
    for pose in poses:
        assert pose.header.frame_id == "map"
        values = [pose.pose.pose.position.x, pose.pose.pose.position.y, *pose.pose.covariance]
        assert np.isfinite(values).all()
    first = next(i for i, p in enumerate(poses) if p.localized)
    t_first = stamp_ns(poses[first]) * 1e-9
    assert t_first <= 30.0, f"localized only at t = {t_first:.1f} s"
    print(
        f"localized at t = {t_first:.2f} s after {first} scans; {len(recorder.clouds)} clouds, "
        f"status {recorder.sim_status}"
    )
    exploring = sum(not p.localized for p in poses)
    assert recorder.commands == exploring + recorder.path_follower_commands, "exactly one /cmd_vel per observation"
    assert len(poses) == recorder.commands + 1, "every command was answered by one observation, the last one pending"
    # the estimate at the first declaration against the ground truth
    truth = recorder.truth[stamp_ns(poses[first])].pose.pose
    estimate = poses[first].pose.pose
    assert math.hypot(estimate.position.x - truth.position.x, estimate.position.y - truth.position.y) <= 0.10
    assert abs(
        float(wrap_angle(yaw_from_quaternion(estimate.orientation) - yaw_from_quaternion(truth.orientation)))
    ) <= math.radians(10)
    # the simulator's check agrees
    status = recorder.sim_status
    assert status.localization_enabled and status.localized
    assert 0.0 < status.first_localized_time <= t_first + 1e-6
    assert status.position_error <= 0.10 and status.heading_error <= math.radians(10)
    # /particle_cloud: throttled to one per CLOUD_PERIOD of scan time
    clouds = recorder.clouds
    assert 2 <= len(clouds) <= stamp_ns(poses[-1]) * 1e-9 / CLOUD_PERIOD + 1
    assert all(c.header.frame_id == "map" for c in clouds)
    gaps = np.diff([stamp_ns(c) for c in clouds]) * 1e-9
    assert (gaps >= CLOUD_PERIOD - 1e-6).all()
    assert len(clouds[0].poses) == PARTICLES and len(clouds[-1].poses) < PARTICLES  # KLD shrank it
    # map -> odom on /tf: composed with the odometry pose it gives the published estimate
    tf = [t for t in recorder.transforms if t.transforms[0].header.frame_id == "map"]
    assert len(tf) == len(poses)
    last = tf[-1].transforms[0]
    assert last.child_frame_id == "odom" and stamp_ns(last) == stamp_ns(poses[-1])
    correction = np.array(
        [last.transform.translation.x, last.transform.translation.y, yaw_from_quaternion(last.transform.rotation)]
    )
    robot = compose(correction[None, :], np.array(odometry_pose(recorder.odometry[stamp_ns(last)])))[0]
    published = poses[-1].pose.pose
    assert robot[:2] == pytest.approx([published.position.x, published.position.y], abs=1e-9)
    assert float(wrap_angle(robot[2] - yaw_from_quaternion(published.orientation))) == pytest.approx(0.0, abs=1e-9)
    # ~/status: one per scan, the particle count it reports is the cloud's
    assert len(recorder.status) == len(poses)
    assert recorder.status[0].particles == PARTICLES and recorder.status[-1].localized


# -- the node alone, fed by a rig -------------------------------------------------------------------


class Rig(Node):
    """Plays a simulator recorded here (outer_corridor) to the filter, with hand-made faults."""

    def __init__(self, context) -> None:
        super().__init__("rig", context=context)
        self.odometry = self.create_publisher(Odometry, "odometry", 10)
        self.scan = self.create_publisher(LaserScan, "scan", qos_profile_sensor_data)
        self.initial = self.create_publisher(PoseWithCovarianceStamped, "initialpose", 10)
        self.poses: list[LocalizedPose] = []
        self.create_subscription(LocalizedPose, "pose", self.poses.append, 100)
        self.sim = Simulator(load_world(WORLDS / "outer_corridor.yaml"))

    def send(self, stamp: float, odometry_pose=None, ranges=None) -> None:
        sim = self.sim
        pose = Pose2D(*(odometry_pose or sim.odom_pose))
        time = stamp_from_seconds(stamp)
        self.odometry.publish(sim_messages.odometry(time, "odom", "base_footprint", pose, (0.0, 0.0, 0.0)))
        scan = sim_messages.laser_scan(time, "base_scan", sim.ranges, sim.lidar, 0.05)
        if ranges is not None:
            scan.ranges = ranges
        self.scan.publish(scan)


def localizer_with_rig(executor, **overrides):
    context = executor.context
    params = {
        "world": "outer_corridor.yaml",
        "lidar_x": -0.032,
        "max_particles": 1000,
        "particle_cloud_period": 0.0,
        **overrides,
    }
    node = ParticleFilterNode(context=context, parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
    rig = Rig(context)
    executor.add_node(node)
    executor.add_node(rig)
    configure_and_activate(node)
    assert spin_until(executor, lambda: rig.count_subscribers("scan") and rig.count_subscribers("odometry"), 5.0)
    return node, rig


def send_one_by_one(executor, rig, send, cases, t: float = 20.0) -> float:
    """send(t, **fault) for each (name, fault) of `cases`, 50 ms apart; each must get its /pose. Returns the next t."""
    for expected, (name, fault) in enumerate(cases, start=1):
        send(t, **fault)
        t += 0.05
        assert spin_until(executor, lambda expected=expected: len(rig.poses) >= expected, 3.0), (
            f"no /pose after the {name}"
        )
    return t


def test_bad_input_is_logged_and_survived_with_one_finite_pose_per_pair(executor):
    node, rig = localizer_with_rig(executor)
    warnings = LoggedWarnings(node)
    sim = rig.sim
    beams = len(sim.ranges)
    cases = [
        ("nan scan", dict(ranges=[math.nan] * beams)),
        ("short scan", dict(ranges=[])),
        ("inf scan", dict(ranges=[math.inf] * beams)),
        ("fine", {}),
        ("nan odometry", dict(odometry_pose=(math.nan, 0.0, 0.0))),
        ("odometry jump", dict(odometry_pose=(sim.odom_pose[0] + 5.0, sim.odom_pose[1], sim.odom_pose[2]))),
        ("fine", {}),
    ]
    t = send_one_by_one(executor, rig, rig.send, cases)
    # stamps going back 10 s (a simulator reset): the pairing restarts, poses keep coming
    rig.send(t - 10.0)
    assert spin_until(executor, lambda: len(rig.poses) >= len(cases) + 1, 3.0), "no /pose after stamps went back"
    log = "\n".join(warnings.lines)
    assert "no valid return" in log  # NaN and inf everywhere: skipped by the filter
    assert "scan refused" in log  # the empty scan
    assert "odometry: pose must be 3 finite numbers" in log
    assert "odometry jumped" in log
    assert "stamps jumped by -9.950 s" in log
    assert_finite(rig.poses)
    assert node.state_label == "active"


def test_initialpose_reseeds_and_reinitialize_spreads_again(executor):
    node, rig = localizer_with_rig(executor)
    message = PoseWithCovarianceStamped()
    message.header.frame_id = "map"
    message.pose.pose.position.x, message.pose.pose.position.y = sim_start = rig.sim.pose.x, rig.sim.pose.y
    message.pose.pose.orientation.w = 1.0
    covariance = np.zeros((6, 6))
    covariance[0, 0] = covariance[1, 1] = 0.05**2
    covariance[5, 5] = 0.05**2
    message.pose.covariance = list(covariance.ravel())
    spread_before = node.filter.particles[:, :2].std(axis=0).max()
    rig.initial.publish(message)
    assert spin_until(executor, lambda: node.filter.particles[:, :2].std(axis=0).max() < 0.1, 3.0)
    assert node.filter.particles[:, :2].mean(axis=0) == pytest.approx(sim_start, abs=0.02)
    assert spread_before > 0.5

    bad = PoseWithCovarianceStamped()
    bad.header.frame_id = "odom"  # wrong frame: refused, particles unchanged
    bad.pose.pose.orientation.w = 1.0
    warnings = LoggedWarnings(node)
    rig.initial.publish(bad)
    assert spin_until(executor, lambda: any("initialpose refused" in line for line in warnings.lines), 3.0)
    assert node.filter.particles[:, :2].std(axis=0).max() < 0.1

    client = rig.create_client(Empty, "particle_filter/reinitialize_global_localization")
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(Empty.Request())
    assert spin_until(executor, future.done, 5.0)
    assert node.filter.particles[:, :2].std(axis=0).max() > 0.5
    assert len(node.filter.particles) == node.filter.config.max_particles


def test_a_map_file_and_a_bad_map_source(executor, tmp_path):
    """map_yaml: a map_server file (saved from the rasterized world) localizes the same way; a missing
    file or both sources at once fail configure naming the problem."""
    from amr_maps.map_io import save_map
    from amr_maps.rasterize import rasterize_world

    path = save_map(rasterize_world(load_world(WORLDS / "outer_corridor.yaml"), 0.05), tmp_path / "corridor.yaml")
    node = ParticleFilterNode(
        context=executor.context,
        parameter_overrides=[Parameter("map_yaml", value=str(path)), Parameter("max_particles", value=500)],
    )
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.filter is not None and len(node.filter.particles) == 500
    node.destroy_node()
    for overrides, problem in (
        (dict(map_yaml=str(tmp_path / "missing.yaml")), "missing.yaml"),
        (dict(map_yaml=str(path), world="outer_corridor.yaml"), "one map source"),
    ):
        node = ParticleFilterNode(
            context=executor.context, parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()]
        )
        assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert problem in node.configure_error
        node.destroy_node()


# -- beacon ranges as a measurement (use_beacons) ---------------------------------------------------

BEACON_STEPS = 160


def test_a_beacons_only_filter_localizes_on_open_room_in_lockstep(executor):
    """open_room declares 4 beacons: use_scan false + use_beacons true pairs /odometry with /beacons only
    (no /scan subscription), answers every reading with one /pose and localizes from a uniform start."""
    context = executor.context
    simulator = SimulatorNode(
        context=context,
        parameter_overrides=[
            Parameter("world", value="open_room.yaml"),
            Parameter("lockstep_resend_period", value=0.0),
        ],
    )
    localizer = ParticleFilterNode(
        context=context,
        parameter_overrides=[
            Parameter("world", value="open_room.yaml"),
            Parameter("use_scan", value=False),
            Parameter("use_beacons", value=True),
            Parameter("max_particles", value=PARTICLES),
        ],
    )
    driver = Driver(context, steps=BEACON_STEPS, v=0.2, w=0.6)  # a 0.33 m circle clear of the walls
    for node in (simulator, localizer, driver):
        executor.add_node(node)
    configure_and_activate(localizer)
    assert localizer.INPUTS == ("odometry", "beacons")
    assert len(localizer.filter.beacons) == 4, "the positions come from the world"
    assert simulator.try_transition(Transition.TRANSITION_CONFIGURE)
    assert spin_until(executor, lambda: simulator.count_subscribers("beacons") >= 2, 5.0)  # driver, filter
    assert simulator.count_subscribers("scan") == 0, "a beacons-only filter does not subscribe /scan"
    assert simulator.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: len(driver.poses) >= BEACON_STEPS, 60.0), f"{len(driver.poses)} poses"
    spin_for(executor, 0.2)

    poses = driver.poses
    assert [stamp_ns(p) for p in poses] == [stamp_ns(r) for r in driver.readings], (
        "one /pose per reading, stamped with it"
    )
    assert all(np.isfinite([p.pose.pose.position.x, p.pose.pose.position.y, *p.pose.covariance]).all() for p in poses)
    assert not poses[0].localized and poses[0].confidence < 0.95, "it starts spread over the room, not declared"
    first = next((i for i, p in enumerate(poses) if p.localized), None)
    assert first is not None, f"not localized after {len(poses)} readings"
    position, heading = driver.error(poses[first])
    print(
        f"beacons only: localized after {first} readings, error {100 * position:.1f} cm, "
        f"{math.degrees(heading):.1f} deg"
    )
    assert position <= 0.05 and heading <= math.radians(5)
    assert all(p.localized for p in poses[first:])
    assert max(driver.error(p)[0] for p in poses[first:]) <= 0.05


class BeaconRig(Rig):
    """The rig, plus /beacons from the simulated reading (open_room's four beacons)."""

    def __init__(self, context, world) -> None:
        Node.__init__(self, "rig", context=context)
        self.odometry = self.create_publisher(Odometry, "odometry", 10)
        self.scan = self.create_publisher(LaserScan, "scan", qos_profile_sensor_data)
        self.beacons = self.create_publisher(BeaconRanges, "beacons", 10)
        self.poses: list[LocalizedPose] = []
        self.create_subscription(LocalizedPose, "pose", self.poses.append, 100)
        self.sim = Simulator(world)

    def send_reading(self, stamp: float, positions=None, ranges=None) -> None:
        real_positions, real_ranges, compass = self.sim.beacon_reading()
        message = sim_messages.beacon_ranges(
            stamp_from_seconds(stamp),
            "map",
            real_positions if positions is None else np.asarray(positions),
            real_ranges if ranges is None else np.asarray(ranges),
            compass,
            self.sim.config.beacons,
        )
        self.beacons.publish(message)
        self.send(stamp)


def test_a_bad_beacon_reading_is_refused_by_name_and_the_filter_keeps_running(executor, tmp_path):
    """Scan + beacons on a world that declares none: the positions come from the first reading; later
    readings with NaN or negative ranges, another count or moved beacons are refused with a log line,
    and every set still gets one finite /pose."""
    import yaml

    data = yaml.safe_load((WORLDS / "open_room.yaml").read_text())
    beacons = data.pop("beacons")
    (tmp_path / "room.yaml").write_text(yaml.safe_dump(data))
    context = executor.context
    node = ParticleFilterNode(
        context=context,
        parameter_overrides=[
            Parameter("world", value=str(tmp_path / "room.yaml")),
            Parameter("use_beacons", value=True),
            Parameter("lidar_x", value=-0.032),
            Parameter("max_particles", value=1000),
        ],
    )
    rig = BeaconRig(context, load_world(WORLDS / "open_room.yaml"))
    executor.add_node(node)
    executor.add_node(rig)
    configure_and_activate(node)
    assert node.INPUTS == ("odometry", "scan", "beacons") and node.filter.beacons is None
    assert spin_until(executor, lambda: all(rig.count_subscribers(t) for t in ("scan", "odometry", "beacons")), 5.0)
    warnings = LoggedWarnings(node)
    moved = [list(b) for b in beacons]
    moved[2][0] += 0.5
    cases = [
        ("fine", {}),
        ("nan range", dict(ranges=[1.0, math.nan, 1.0, 1.0])),
        ("negative range", dict(ranges=[1.0, -1.0, 1.0, 1.0])),
        ("three beacons", dict(positions=beacons[:3], ranges=[1.0, 1.0, 1.0])),
        ("moved beacon", dict(positions=moved)),
        ("fine", {}),
    ]
    send_one_by_one(executor, rig, rig.send_reading, cases)
    np.testing.assert_array_equal(node.filter.beacons, beacons)
    log = "\n".join(warnings.lines)
    assert "/beacons reading refused (beacon ranges: range 1 is nan: every range must be a finite number >= 0)" in log
    assert "beacon ranges: range 1 is -1.0" in log
    assert "beacons: 3 beacon positions, expected 4" in log
    assert "beacon 2 at (2.400, 1.400), expected (1.900, 1.400) (positions changed)" in log
    assert log.count("/beacons reading refused") == 4, log
    assert_finite(rig.poses)
    assert node.state_label == "active"


def test_use_beacons_and_use_scan_are_structural_and_one_is_needed(executor):
    node = ParticleFilterNode(
        context=executor.context,
        parameter_overrides=[Parameter("world", value="open_room.yaml"), Parameter("use_scan", value=False)],
    )
    assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert "use_scan and use_beacons are both false" in node.configure_error
    assert node.set_parameters([Parameter("use_beacons", value=True)])[0].successful
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    result = node.set_parameters([Parameter("use_scan", value=True)])[0]
    assert not result.successful and "read-only while configured" in result.reason
    descriptor = node.describe_parameter("use_beacons")
    assert descriptor.name == "use_beacons" and "/beacons" in descriptor.description
