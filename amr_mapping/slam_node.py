"""slam: online 2D graph SLAM as a lifecycle node (`ros2 run amr_mapping slam`), a thin shell over
amr_mapping.slam.GraphSlam.

configure  reads the parameters (SlamConfig's, the library's own, plus the node's below), builds GraphSlam and
           the topics. The map frame is where the robot started: its first scan's pose is (0, 0, 0).
active     /odometry + /scan are paired by stamp (amr_util.sync, the approximate-time policy, as the particle
           filter pairs them); each pair is one GraphSlam.add and gets, stamped with the scan's stamp:
           /pose (amr_interfaces/LocalizedPose in the map frame, localized true, confidence 1.0: the navigator
           and the lockstep simulator take it as they take the filter's), map -> odom on /tf, ~/status
           (amr_interfaces/LocalizerStatus: updated = a node was added, confidence 1, update_time,
           event = loop closures or the library's events).
           /map (nav_msgs/OccupancyGrid, stamped with the scan's stamp it was asked for at) and ~/graph
           (amr_interfaces/PoseGraph, its newest node's stamp), both transient local, go out when the map changed,
           at most every map_publish_period s of scan time (a steady timer asks for a change left over when no scan
           comes: a lockstep simulator holding the robot). They are built and published on the node's own thread
           (MapWorker, as slam_toolbox builds its map beside its scan processing): the callback answering a pair
           only asks for one, and the thread takes a snapshot of the graph (GraphSlam.snapshot, under the lock
           GraphSlam.add and a save's settle are called under), brings its kept map to it
           (amr_mapping.slam.KeptMap) outside the lock, waiting between chunks of the build while a pair is
           answered (one thread of Python runs at a time), and publishes. One build at a time; asking during a
           build makes one more after it (the newest ask's stamp), never a queue. The thread starts on activate
           and is stopped and joined on deactivate, cleanup and destroy (nothing is published after deactivate).
           ~/save_map (amr_interfaces/SaveMap) writes <path>.yaml, <path>.pgm and <path>.poses.csv; a path that
           cannot be written is answered success false with the reason, and the map is kept. The optimization a
           save needs (GraphSlam.settle) and the snapshot are taken under the lock; the map is rebuilt and written
           from the snapshot outside it (amr_mapping.slam.save_snapshot: intel's 905 nodes 0.4 s against 0.1 s of
           optimization), so the map thread is not held up by the writing. Pairs wait for the answer, as for any
           callback of the node's one executor.

One /pose answers every pair, so a lockstep loop that waits for it never stalls: an input the library refuses
(MappingError), or a failure of the library, is logged and the pose follows odometry from the last correction. Nothing
non-finite is published; no exception leaves a callback or the map thread (a failed build is logged and the thread
goes on). Stamps going back (a simulator reset) restart the pairing with a log line; the map is kept (the world did
not change).
"""

from __future__ import annotations

import dataclasses
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from builtin_interfaces.msg import Time as TimeMessage
from geometry_msgs.msg import Pose2D as Pose2DMessage
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.time import Time
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from amr_interfaces.msg import LocalizedPose, LocalizerStatus, PoseGraph
from amr_interfaces.srv import SaveMap
from amr_mapping.errors import MappingError
from amr_mapping.slam import GraphSlam, KeptMap, SlamConfig, save_snapshot
from amr_maps.messages import grid_message
from amr_util.geometry import all_finite, compose, yaw_from_quaternion
from amr_util.managed_node import WARNING_PERIOD, ManagedNode, run
from amr_util.messages import quaternion, scan_data, transform
from amr_util.parameter_spec import ParameterSpec, field_docs
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_util.stamps import NANOSECONDS_PER_SECOND, stamp_from_nanoseconds
from amr_util.sync import ApproximateTimeSynchronizer

NODE_NAME = "slam"
"""s between repeats of one kind of warning."""
FLUSH_PERIOD = 0.5
"""s (wall clock) between checks for a map change left unpublished."""
JOIN_TIMEOUT = 30.0
"""s a deactivate waits for the map thread's build in progress (a rebuild at 900 nodes takes 0.1-0.2 s)."""
PAUSE_LIMIT = 1.0
"""s the map thread waits at most, between two chunks of its build, for a pair being answered (one thread of Python
runs at a time: a build going on beside the answer would take half its turns)."""

NODE_SPECS = (
    ParameterSpec(
        "global_frame_id",
        "map",
        "frame of /map, /pose and ~/graph: the parent of the published "
        "transform; its origin is the robot's pose at the first scan",
    ),
    ParameterSpec("odom_frame_id", "odom", "frame of the odometry: the child of the published transform"),
    ParameterSpec("tf_broadcast", True, "publish map -> odom on /tf after every pair processed"),
    ParameterSpec(
        "map_publish_period",
        1.0,
        "s of scan time at least between two /map (and ~/graph) messages; each goes out once the map changed",
        minimum=0.0,
        maximum=3600.0,
        live=True,
    ),
    ParameterSpec(
        "sync_slop",
        0.05,
        "s, the stamps of a paired /odometry and /scan differ by at most this",
        minimum=0.0,
        maximum=100.0,
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
NODE_NAMES = frozenset(spec.name for spec in NODE_SPECS)


def library_specs() -> tuple[ParameterSpec, ...]:
    """SlamConfig's fields as parameters: each field's default (its type) and docstring; the library's own
    construction checks the values (MappingError naming the key) when the node configures."""
    if hasattr(SlamConfig, "parameter_specs"):  # an amr_util.parameter_spec.Config
        return tuple(SlamConfig.parameter_specs())
    docs = field_docs(SlamConfig)
    return tuple(
        ParameterSpec(f.name, f.default, docs.get(f.name, ""))
        for f in dataclasses.fields(SlamConfig)
        if f.default is not dataclasses.MISSING
    )


def parameter_specs() -> tuple[ParameterSpec, ...]:
    """SlamConfig's parameters (the library's own) and the node's."""
    return library_specs() + NODE_SPECS


def config_of(values: dict) -> SlamConfig:
    """The library's configuration from the node's parameter values (the node's own keys left out)."""
    names = {field.name for field in dataclasses.fields(SlamConfig)}
    return SlamConfig(**{name: value for name, value in values.items() if name in names})


def odometry_pose(message: Odometry) -> tuple[float, float, float]:
    pose = message.pose.pose
    return float(pose.position.x), float(pose.position.y), yaw_from_quaternion(pose.orientation)


def localized_pose(stamp: TimeMessage, frame: str, pose) -> LocalizedPose:
    """The SLAM pose as a localizer's: localized, confidence 1, covariance 0 (the graph's is not estimated)."""
    message = LocalizedPose(localized=True, confidence=1.0, runner_up_confidence=0.0)
    message.header.stamp, message.header.frame_id = stamp, frame
    message.pose.pose.position.x, message.pose.pose.position.y = float(pose[0]), float(pose[1])
    message.pose.pose.orientation = quaternion(float(pose[2]))
    return message


def pose_graph_message(stamp: TimeMessage, frame: str, poses, edges, loop) -> PoseGraph:
    message = PoseGraph()
    message.header.stamp, message.header.frame_id = stamp, frame
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    message.poses = [Pose2DMessage(x=float(x), y=float(y), theta=float(t)) for x, y, t in poses]
    message.edge_from = [int(v) for v in edges[:, 0]]
    message.edge_to = [int(v) for v in edges[:, 1]]
    message.loop_closure = [bool(v) for v in np.asarray(loop, dtype=bool).reshape(-1)]
    return message


class MapWorker:
    """A thread of its own that runs `job(request)` for the newest request, one job at a time: a request made
    during a job makes one more job after it (coalesced: the newest request, never a queue). No exception leaves
    the thread: `on_error(error)` is called and the thread goes on. Executor-independent (a plain thread); a
    daemon, so a job that never ends does not hold the process."""

    def __init__(self, job: Callable[[object], None], on_error: Callable[[BaseException], None], name: str) -> None:
        self._job, self._on_error = job, on_error
        self._wake = threading.Condition()
        self._request: object | None = None
        self._stop = False
        self._busy = False  # a job in progress
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def request(self, value: object) -> None:
        """A job for `value`, after the one in progress if any (replacing a request not started yet)."""
        with self._wake:
            self._request = value
            self._wake.notify()

    @property
    def stopping(self) -> bool:
        return self._stop

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def stop(self, timeout: float = JOIN_TIMEOUT) -> bool:
        """Stops the thread after the job in progress, drops a request not started and joins; True when a request
        was left undone (dropped, or its job in progress when asked to stop). Safe to call twice, or before start."""
        with self._wake:
            self._stop = True
            left = self._request is not None or self._busy
            self._request = None
            self._wake.notify()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout)
        return left

    def _run(self) -> None:
        while True:
            with self._wake:
                while self._request is None and not self._stop:
                    self._wake.wait()
                if self._stop:
                    return
                value, self._request = self._request, None
                self._busy = True
            try:
                self._job(value)
            except Exception as error:  # the thread outlives a failed job
                try:
                    self._on_error(error)
                except Exception:
                    pass
            finally:
                self._busy = False


class SlamNode(ManagedNode):
    """Wires GraphSlam to /odometry, /scan, /map, /pose, /tf, ~/graph, ~/status and ~/save_map; no mapping logic."""

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(parameter_specs())
        self.slam: GraphSlam | None = None
        self._sync: ApproximateTimeSynchronizer | None = None
        self._settings: dict = {}
        self._outputs: dict = {}
        self._entities: list = []
        self._timer = None
        self._slam_lock = threading.Lock()  # GraphSlam.add, save and the map thread's snapshot
        self._idle = threading.Event()  # clear while a pair is answered: the map thread's build waits
        self._idle.set()
        self._kept_map: KeptMap | None = None  # the map thread's
        self._map_worker: MapWorker | None = None
        self._map_dirty = False
        self._last_map_ns: int | None = None
        self._last_map_wall = -math.inf
        self._last_stamp: TimeMessage | None = None
        self.maps_published = 0
        self.pairs = 0
        self.configure_error = ""

    # -- lifecycle ------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        values = self.parameter_values()
        if not problems:
            try:
                self.slam = GraphSlam(config_of(values))
                self._kept_map = KeptMap(self.slam.config.resolution)
            except ValueError as error:  # ConfigError, MappingError name the key
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            self.slam = None
            return self.fail_configure(problems)
        self._settings = {name: values[name] for name in NODE_NAMES}
        self._sync = ApproximateTimeSynchronizer(
            2,
            values["sync_slop"],
            values["sync_queue_size"],
            self._on_pair,
            jump_threshold=values["stamp_jump_threshold"],
            on_jump=self._on_clock_jump,
        )
        self._outputs = {
            "map": self.create_lifecycle_publisher(OccupancyGridMessage, "map", LATCHED),
            "graph": self.create_lifecycle_publisher(PoseGraph, "~/graph", LATCHED),  # a late viewer gets it too
            "pose": self.create_lifecycle_publisher(LocalizedPose, "pose", reliable()),
            "status": self.create_lifecycle_publisher(LocalizerStatus, "~/status", reliable()),
        }
        if values["tf_broadcast"]:  # relative, as the particle filter's: /tf, or /r1/tf in a robot's namespace
            self._outputs["tf"] = self.create_lifecycle_publisher(TFMessage, "tf", reliable(100))
        self._entities = [
            self.create_subscription(
                Odometry, "odometry", lambda m: self._on_message(0, m), reliable(values["sync_queue_size"])
            ),
            self.create_subscription(LaserScan, "scan", lambda m: self._on_message(1, m), SENSOR_DATA),
            self.create_active_service(SaveMap, "~/save_map", self._on_save_map),
        ]
        self.get_logger().info(
            "configured: /odometry + /scan paired into the pose graph; /map in frame "
            f"{values['global_frame_id']} (the robot's start), at most every "
            f"{values['map_publish_period']} s"
        )
        return TransitionCallbackReturn.SUCCESS

    def apply_live(self, changes: dict) -> None:
        """map_publish_period (the node's) while configured; the library's parameters are structural here."""
        library = [name for name in changes if name not in NODE_NAMES]
        if library:
            raise ValueError(f"{', '.join(library)}: the graph is built with it; cleanup, set, configure")
        self._settings.update(changes)

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        if self._sync is not None:
            self._sync.reset()
        self._timer = self.create_timer(FLUSH_PERIOD, self._flush, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._stop_map_worker()
        self._map_worker = MapWorker(self._build_map, self._on_map_error, f"{self.get_name()} map")
        self._map_worker.start()
        return super().on_activate(state)

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        self._stop_map_worker()  # joined before the publishers are deactivated: nothing published after
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._stop_map_worker()
        self._entities, self._outputs = [], {}
        self.slam = self._sync = self._last_stamp = self._kept_map = None
        self._map_dirty, self._last_map_ns = False, None
        return super().on_cleanup(state)  # destroys what configure made

    def destroy_node(self) -> None:
        self._stop_map_worker()
        super().destroy_node()

    def _stop_map_worker(self) -> None:
        """The map thread stopped after its build in progress and joined; a map asked for and not published is
        asked again by the next scan or the flush timer once active again."""
        worker, self._map_worker = self._map_worker, None
        if worker is None:
            return
        if worker.stop():
            self._map_dirty = True
        if worker.alive:  # its build goes on with the kept map it holds: the next thread gets a fresh one
            self.get_logger().error(f"the map thread did not stop within {JOIN_TIMEOUT} s: left to end on its own")
            if self._kept_map is not None:
                self._kept_map = KeptMap(self._kept_map.resolution)

    # -- inputs ---------------------------------------------------------------------------------

    def _on_message(self, index: int, message) -> None:
        self.feed_synchronizer(self._sync, index, message, self.warn_throttled)

    def _on_clock_jump(self, index: int, jump_ns: int) -> None:
        self.get_logger().warning(
            f"/{('odometry', 'scan')[index]} stamps jumped by {jump_ns * 1e-9:+.3f} s: "
            "pairing restarted (the map is kept)"
        )
        self._last_map_ns = None

    def _on_pair(self, odometry: Odometry, scan: LaserScan) -> None:
        """One GraphSlam.add per pair, then /pose, map -> odom and ~/status with the scan's stamp; /map and ~/graph
        when the map changed and map_publish_period has passed (asked of the map thread, which waits meanwhile)."""
        self._idle.clear()
        try:
            self._process(odometry, scan)
        except Exception as error:  # a library bug must not take the node down (nor stall a lockstep loop)
            self.get_logger().error(
                f"slam update failed: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD
            )
        finally:
            self._idle.set()

    def _process(self, odometry: Odometry, scan: LaserScan) -> None:
        slam, stamp = self.slam, scan.header.stamp
        stamp_ns = Time.from_msg(stamp).nanoseconds
        odom = odometry_pose(odometry)
        if not all_finite(odom):
            self.warn_throttled("odometry is not finite: the pair was dropped")
            return
        status = LocalizerStatus(localized=True, clusters=1, confidence=1.0)
        try:
            data = scan_data(scan)
            with self._slam_lock:
                update = slam.add(stamp_ns, odom, data)
            pose = tuple(float(v) for v in update.pose)
            status.updated, status.update_time = bool(update.node_added), float(update.seconds)
            for event in update.events:
                self.get_logger().info(event, throttle_duration_sec=WARNING_PERIOD)
            status.event = "; ".join(update.events)
            self._map_dirty |= bool(update.map_changed)
        except Exception as error:  # MappingError: refused input; anything else a library bug. Either way a /pose
            # answers the pair (a lockstep loop waits for it): odometry from the last correction
            if isinstance(error, MappingError):
                self.warn_throttled(f"scan refused ({error}): the pose follows odometry")
            else:
                self.get_logger().error(
                    f"slam update failed: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD
                )
            status.event = f"update refused: {error}"
            pose = tuple(compose(tuple(slam.map_to_odom), odom))
        self.pairs += 1
        self._publish_pose(stamp, pose, status)
        period = round(self._settings["map_publish_period"] * NANOSECONDS_PER_SECOND)
        due = self._last_map_ns is None or stamp_ns - self._last_map_ns >= period or stamp_ns < self._last_map_ns
        if self._map_dirty and due:
            self._last_map_ns = stamp_ns
            self._request_map(stamp)

    def _on_save_map(self, request: SaveMap.Request, response: SaveMap.Response) -> SaveMap.Response:
        try:
            if self.slam is None:
                raise MappingError("no map yet")
            path = Path(request.path).expanduser() if request.path else None
            if path is None:
                raise MappingError("path is empty: give a file path without extension (e.g. my_map)")
            with self._slam_lock:  # the optimization a save needs, and the graph it writes; the writing outside
                moved = self.slam.settle()
                snapshot, config = self.slam.snapshot(), self.slam.config
            if moved:  # the save finished an optimization: /map follows the poses saved (the next pair or the flush)
                self._map_dirty = True
            written = save_snapshot(snapshot, config, path)
            response.success = True
            response.message = "wrote " + ", ".join(str(p) for p in written)
            self.get_logger().info(f"map saved: {response.message}")
        except Exception as error:  # MappingError names the path; anything else must not escape either
            response.success = False
            response.message = (
                str(error) if isinstance(error, (MappingError, OSError)) else f"{type(error).__name__}: {error}"
            )
            self.get_logger().warning(f"save_map {request.path!r} failed: {response.message} (the map is kept)")
        return response

    # -- outputs --------------------------------------------------------------------------------

    def _publish_pose(self, stamp: TimeMessage, pose, status: LocalizerStatus) -> None:
        if not all_finite(pose):
            self.get_logger().error("the pose is not finite: nothing published", throttle_duration_sec=WARNING_PERIOD)
            return
        frame = self._settings["global_frame_id"]
        self._last_stamp = stamp
        self._outputs["pose"].publish(localized_pose(stamp, frame, pose))
        correction = tuple(float(v) for v in self.slam.map_to_odom)
        if "tf" in self._outputs and all_finite(correction):
            self._outputs["tf"].publish(transform(stamp, frame, self._settings["odom_frame_id"], correction))
        status.header.stamp, status.header.frame_id = stamp, frame
        self._outputs["status"].publish(status)

    def _request_map(self, stamp: TimeMessage) -> None:
        """/map and ~/graph asked of the map thread (built and published there, stamped `stamp`): the change is
        taken as published (a later change marks the map again)."""
        worker = self._map_worker
        if worker is None:
            return
        self._map_dirty = False
        self._last_map_wall = time.monotonic()
        worker.request(stamp)

    def _build_map(self, stamp: TimeMessage) -> None:
        """The map thread's job: a snapshot of the graph under the lock, the kept map brought to it outside, then
        /map and ~/graph (nothing when a pose is not finite, or when the thread is being stopped)."""
        with self._slam_lock:
            slam, kept = self.slam, self._kept_map
            if slam is None or kept is None:
                return
            snapshot = slam.snapshot()
        if not snapshot.nodes:
            return
        frame, outputs = self._settings["global_frame_id"], self._outputs
        if not np.isfinite(snapshot.poses).all():
            raise MappingError("a node's pose is not finite: no /map nor ~/graph published")
        grid = kept.build(snapshot, pause=self._pause)
        if grid.frame_id != frame:
            grid = dataclasses.replace(grid, frame_id=frame)
        if not all_finite(grid.origin):
            raise MappingError(f"the map's origin {grid.origin} is not finite: not published")
        message = grid_message(grid, stamp)
        graph_stamp = stamp_from_nanoseconds(int(snapshot.node_stamps[-1]))
        graph = pose_graph_message(graph_stamp, frame, snapshot.poses, snapshot.edges, snapshot.loop)
        self._pause()
        worker = self._map_worker
        if worker is None or worker.stopping:  # deactivating: the publishers are about to be (MapWorker.stop says)
            return
        outputs["map"].publish(message)
        outputs["graph"].publish(graph)
        self.maps_published += 1

    def _pause(self) -> None:
        """The map thread's build waits while a pair is being answered (at most PAUSE_LIMIT s at a time)."""
        self._idle.wait(PAUSE_LIMIT)

    def _on_map_error(self, error: BaseException) -> None:
        self.get_logger().error(
            f"map not published: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD
        )

    def _flush(self) -> None:
        """A map change no later scan asked for (a lockstep simulator holding the robot) goes out after a period."""
        if self.state_label != "active" or not self._map_dirty or self._last_stamp is None or self.slam is None:
            return
        if time.monotonic() - self._last_map_wall < max(self._settings["map_publish_period"], FLUSH_PERIOD):
            return
        self._request_map(self._last_stamp)


def main(args=None) -> None:
    run(SlamNode, args=args)


if __name__ == "__main__":
    main()
