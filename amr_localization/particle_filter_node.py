"""particle_filter: Monte Carlo localization as a lifecycle node (`ros2 run amr_localization particle_filter`).

A thin shell over amr_localization.particle_filter.ParticleFilter:

configure  reads the parameters and the map (`world`, rasterized; or `map_yaml`, a map_server file;
           else the `map` topic, transient local: the filter is built when the first map arrives),
           builds the filter (particles uniform over free space: global localization) and its topics.
active     /odometry + /scan (use_scan) + /beacons (use_beacons: amr_interfaces/BeaconRanges) are paired by
           stamp (amr_util.sync, the approximate-time policy); each set is one filter update and gets, all
           stamped with the scan's stamp (the beacons' without a scan):
           /pose (amr_interfaces/LocalizedPose, frame map), map -> odom on /tf, ~/status, and
           /particle_cloud (geometry_msgs/PoseArray) at most every particle_cloud_period seconds.
           /initialpose (RViz's 2D Pose Estimate) re-seeds around a pose;
           ~/reinitialize_global_localization (std_srvs/Empty) spreads the particles again.

One /pose answers every set, so a lockstep loop that waits for it never stalls: a scan the filter
refuses (too short, malformed) is logged and the update goes on without it (by the beacons if used, else
the pose moves by odometry alone); so does a beacon reading it refuses (NaN or negative ranges, other
beacon positions or another count than the world's or the first reading's); odometry it refuses
(NaN) is logged and the last pose is repeated. Nothing non-finite is published; no exception leaves
a callback. Stamps going back (a simulator reset) restart the pairing with a log line; an odometry
jump is taken as a reset of odometry, not as motion (the library's event, logged).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from builtin_interfaces.msg import Time as TimeMessage
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from nav_msgs.msg import Odometry
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.time import Time
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty

from amr_interfaces.msg import BeaconRanges
from amr_localization import messages
from amr_localization.beacons import BeaconReading, checked_beacons
from amr_localization.errors import BeaconError, LocalizationError, OdometryError, ScanError
from amr_localization.localizer_node import SHELL_SPECS, LocalizerNode
from amr_localization.particle_filter import Estimate, ParticleFilter
from amr_localization.particle_filter_parameters import NODE_SPECS, config_of, parameter_specs
from amr_maps.map_io import load_map
from amr_maps.messages import grid_from_message
from amr_maps.occupancy_grid import OccupancyGrid
from amr_maps.rasterize import rasterize_world
from amr_maps.world import load_world, resolve_world_path
from amr_util.managed_node import WARNING_PERIOD, run
from amr_util.messages import scan_data
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_util.stamps import NANOSECONDS_PER_SECOND

NODE_NAMES = frozenset(spec.name for spec in NODE_SPECS + SHELL_SPECS)


class ParticleFilterNode(LocalizerNode):
    """Wires ParticleFilter to topics, services and the lifecycle; holds no estimation logic."""

    INPUTS = ("odometry", "scan")
    """The default; configure sets this node's own from use_scan and use_beacons (odometry first)."""

    def __init__(self, **kwargs) -> None:
        super().__init__("particle_filter", **kwargs)
        self.declare_specs(parameter_specs() + SHELL_SPECS)
        self.filter: ParticleFilter | None = None
        self._inputs: list = []
        self._node_services: list = []
        self._last_estimate: Estimate | None = None
        self._waiting: tuple | None = None  # the inputs of an observation that came before the map
        self._last_cloud_ns: int | None = None
        self._beacon_positions: np.ndarray | None = None
        self.configure_error = ""

    # -- lifecycle ------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        values = self.parameter_values()
        self._beacon_positions = None
        if not problems:
            try:
                if not (values["use_scan"] or values["use_beacons"]):
                    raise LocalizationError(
                        "use_scan and use_beacons are both false: the filter has nothing to measure (set at least one)"
                    )
                self._config = config_of(values)
                grid = self._static_map(values)
                self.filter = self._build_filter(grid) if grid is not None else None
            except (ValueError, OSError) as error:  # LocalizationError, MapError, WorldError name the problem
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            self.filter = None
            return self.fail_configure(problems)
        self._settings = {name: values[name] for name in NODE_NAMES}
        self.INPUTS = ("odometry",) + ("scan",) * values["use_scan"] + ("beacons",) * values["use_beacons"]
        self._start_pairing(values, self._on_pair)
        self._create_interfaces(values)
        source = values["world"] or values["map_yaml"] or f"topic {values['map_topic']} (waiting)"
        beacons = ""
        if values["use_beacons"]:
            beacons = (
                f"; {len(self._beacon_positions)} beacons from the world"
                if self._beacon_positions is not None
                else "; beacon positions from the first /beacons reading"
            )
        self.get_logger().info(
            f"configured: map from {source}, "
            f"{self.filter.config.max_particles if self.filter else 0} particles spread over free space; "
            f"paired: {' + '.join('/' + name for name in self.INPUTS)}{beacons}"
        )
        return TransitionCallbackReturn.SUCCESS

    def _static_map(self, values: dict) -> OccupancyGrid | None:
        if values["world"] and values["map_yaml"]:
            raise LocalizationError("world and map_yaml: give one map source, not both")
        if values["world"]:
            world = load_world(resolve_world_path(values["world"]))
            if values["use_beacons"] and world.beacons:
                self._beacon_positions = checked_beacons(world.beacons)
            return rasterize_world(world, values["map_resolution"], frame_id=values["global_frame_id"])
        if values["map_yaml"]:
            return load_map(Path(values["map_yaml"]).expanduser(), frame_id=values["global_frame_id"])
        return None

    def _build_filter(self, grid: OccupancyGrid) -> ParticleFilter:
        return ParticleFilter(
            grid, self._config, range_max=self.get_parameter("laser_max_range").value, beacons=self._beacon_positions
        )

    def _create_interfaces(self, values: dict) -> None:
        qos = reliable(values["sync_queue_size"])
        self._create_estimate_outputs(values)
        self._outputs["cloud"] = self.create_lifecycle_publisher(PoseArray, "particle_cloud", reliable(2))
        kinds = {"odometry": (Odometry, qos), "scan": (LaserScan, SENSOR_DATA), "beacons": (BeaconRanges, qos)}
        self._inputs = [
            self.create_subscription(kinds[name][0], name, self._input_callback(index), kinds[name][1])
            for index, name in enumerate(self.INPUTS)
        ]
        self._inputs.append(
            self.create_subscription(PoseWithCovarianceStamped, "initialpose", self._on_initial_pose, reliable())
        )
        if self.filter is None:
            self._inputs.append(
                self.create_subscription(OccupancyGridMessage, values["map_topic"], self._on_map, LATCHED)
            )
        self._node_services = [
            self.create_active_service(Empty, "~/reinitialize_global_localization", self._on_reinitialize)
        ]

    def _input_callback(self, index: int):
        return lambda message: self._on_message(index, message)

    def apply_live(self, changes: dict) -> None:
        """Tunables while configured: the whole new configuration is checked, then used from the next update."""
        config = config_of({**self.parameter_values(), **changes})
        if self.filter is not None:
            self.filter.retune(config)
        self._config = config
        self._settings.update({name: value for name, value in changes.items() if name in NODE_NAMES})

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._sync.reset()
        self._last_cloud_ns = None
        return super().on_activate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._inputs, self._node_services, self._outputs = [], [], {}
        self.filter = self._sync = self._last_estimate = self._beacon_positions = self._waiting = None
        return super().on_cleanup(state)  # destroys what configure made

    # -- inputs ---------------------------------------------------------------------------------

    def _on_map(self, message: OccupancyGridMessage) -> None:
        try:
            self.filter = self._build_filter(grid_from_message(message))
            self._last_estimate = None
            self.get_logger().info(
                f"map received ({message.info.width} x {message.info.height} cells at "
                f"{message.info.resolution} m): global localization starts"
            )
        except Exception as error:  # a malformed map or one without free space: keep the previous filter
            self.get_logger().error(f"map refused: {error}")
            return
        waiting, self._waiting = self._waiting, None
        if waiting is not None and self.state_label == "active":
            self._on_pair(*waiting)

    def _on_clock_jump(self, index: int, jump_ns: int) -> None:
        super()._on_clock_jump(index, jump_ns)
        self._last_cloud_ns = None

    def _on_pair(self, *inputs) -> None:
        """One filter update per set of inputs, then one /pose (+ tf, status, maybe cloud) with the scan's stamp
        (the beacon reading's without a scan)."""
        named = dict(zip(self.INPUTS, inputs, strict=True))
        odometry, scan, beacons = named["odometry"], named.get("scan"), named.get("beacons")
        if self.filter is None:
            self._waiting = inputs  # answered when the map arrives: a lockstep loop would wait for it for ever
            self.warn_throttled(f"no map yet (waiting on {self._settings['map_topic']}): the observation waits for it")
            return
        try:
            stamp = (scan if scan is not None else beacons).header.stamp
            estimate = self._update(odometry, scan, beacons, stamp.sec + stamp.nanosec * 1e-9)
        except Exception as error:  # a filter bug must not take the node down: repeat the last pose
            self.get_logger().error(
                f"filter update failed: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD
            )
            estimate = self._last_estimate
        if estimate is None:
            return
        if estimate.status.event:
            self.warn_throttled(estimate.status.event)
        self._publish((scan if scan is not None else beacons).header.stamp, odometry, estimate)

    def _update(
        self, odometry: Odometry, scan: LaserScan | None, beacons: BeaconRanges | None, stamp: float
    ) -> Estimate | None:
        pose = messages.odometry_pose(odometry)
        reading = self._beacon_reading(beacons) if beacons is not None else None
        scan_reading = scan_data(scan) if scan is not None else None
        try:
            return self.filter.update(pose, scan_reading, beacons=reading, stamp=stamp)
        except OdometryError as error:
            self.warn_throttled(f"{error}: the last pose is repeated")
            return self._last_estimate
        except ScanError as error:
            alone = "the beacons and odometry" if reading is not None else "odometry alone"
            self.warn_throttled(f"scan refused ({error}): the pose follows {alone}")
            return self.filter.update(pose, beacons=reading, stamp=stamp)
        except BeaconError as error:
            self.warn_throttled(
                f"/beacons reading refused ({error}): the pose follows "
                + ("the scan and odometry" if scan_reading is not None else "odometry alone")
            )
            return self.filter.update(pose, scan_reading, stamp=stamp)

    def _beacon_reading(self, message: BeaconRanges) -> BeaconReading | None:
        """The reading, checked against the filter's beacons (the first good reading's positions when the
        world declared none); None, logged, when it is refused: the update goes on without it."""
        try:
            if self._beacon_positions is None:
                self.filter.set_beacons(messages.beacon_positions(message))  # checked there
                self._beacon_positions = self.filter.beacons
                self.get_logger().info(
                    f"beacon positions from the first /beacons reading: {np.round(self._beacon_positions, 3).tolist()}"
                )
            return messages.beacon_reading(message, self._beacon_positions)
        except LocalizationError as error:
            without = "the scan and odometry" if self._settings["use_scan"] else "odometry alone"
            self.warn_throttled(f"/beacons reading refused ({error}): the pose follows {without}")
            return None

    def _on_initial_pose(self, message: PoseWithCovarianceStamped) -> None:
        try:
            frame = self._settings["global_frame_id"]
            if message.header.frame_id not in ("", frame):
                raise LocalizationError(f"initial pose: frame {message.header.frame_id!r}, expected {frame!r}")
            if self.filter is None:
                raise LocalizationError("initial pose: no map yet")
            x, y, theta, covariance = messages.initial_pose(message.pose)
            self.filter.initialize_pose(x, y, theta, covariance)
            self._last_cloud_ns = None
            self.get_logger().info(
                f"initial pose ({x:.3f}, {y:.3f}, {math.degrees(theta):.1f} deg): "
                f"{len(self.filter.particles)} particles around it"
            )
        except Exception as error:
            self.get_logger().warning(f"/initialpose refused: {error}")

    def _on_reinitialize(self, request: Empty.Request, response: Empty.Response) -> Empty.Response:
        try:
            if self.filter is None:
                raise LocalizationError("no map yet")
            self.filter.reinitialize_global()
            self._last_cloud_ns = None
            self.get_logger().info(f"global localization: {len(self.filter.particles)} particles over free space")
        except Exception as error:
            self.get_logger().warning(f"reinitialize_global_localization refused: {error}")
        return response

    # -- outputs --------------------------------------------------------------------------------

    def _publish(self, stamp: TimeMessage, odometry: Odometry, estimate: Estimate) -> None:
        status = messages.localizer_status(estimate.status, estimate.localized)
        if not self._publish_estimate(stamp, odometry, estimate.pose, estimate.localized, status):
            return
        self._last_estimate = estimate
        now = Time.from_msg(stamp).nanoseconds
        period = round(self._settings["particle_cloud_period"] * NANOSECONDS_PER_SECOND)
        if self._last_cloud_ns is None or now - self._last_cloud_ns >= period or now < self._last_cloud_ns:
            self._last_cloud_ns = now
            self._outputs["cloud"].publish(
                messages.particle_cloud(stamp, self._settings["global_frame_id"], self.filter.particles)
            )


def main(args=None) -> None:
    run(ParticleFilterNode, args=args)


if __name__ == "__main__":
    main()
