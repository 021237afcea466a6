"""viewer: a live view of any stack in the browser, with the simulator's controls (`ros2 run amr_viewer viewer`).

configure  starts the web server (viser) on `host`:`port` (localhost unless told otherwise; there is no
           authentication: whoever reaches the address can drive the robot) and builds the page.
activate   looks at the graph every `discovery_period` and subscribes to what it finds (every robot namespace, the
           simulators, the IK services' arms, the lifecycle nodes); redraws every `draw_period` while a browser is
           connected.
deactivate stops looking and drawing (the page stays up); cleanup stops the server.

A thin shell over amr_viewer's plain classes: topics are taken raw where they are busy (/tf, /ground_truth, /scan,
/particle_cloud, statuses: a lockstep run publishes them every step) and decoded at draw time, so the view costs
the stack little (bench/bench_viewer.py); a SLAM node's pose graph and the explorer's frontiers are read straight
from CDR too (bytes that are not plain CDR, XCDR2, are deserialized by rclpy instead). A map, graph or frontiers
message in a wrong frame or with a NaN is skipped and logged once.
Every request made from the page runs on this node's executor (a guard condition wakes it); every service call has
a deadline, and its answer (a refusal too) is shown as the node gives it.
"""

from __future__ import annotations

import contextlib
import io
import queue
import time
from collections import deque
from collections.abc import Callable, Collection

from geometry_msgs.msg import PoseArray, PoseStamped, PoseWithCovarianceStamped
from lifecycle_msgs.srv import GetState
from nav_msgs.msg import OccupancyGrid, Odometry, Path
from rclpy.clock import Clock, ClockType
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState, LaserScan
from std_srvs.srv import Empty, Trigger
from tf2_msgs.msg import TFMessage

from amr_interfaces.msg import BeaconRanges, Frontiers, LocalizedPose, PoseGraph, SimulatorStatus
from amr_maps.world import load_world, resolve_world_path
from amr_util.geometry import Pose2D
from amr_util.managed_node import ManagedNode, run
from amr_util.qos import LATCHED, SENSOR_DATA, reliable
from amr_viewer import cdr, messages, replies, status, topics
from amr_viewer.arms import ArmSet
from amr_viewer.clicks import GOAL, ClickTool, pose_topic, sent_text
from amr_viewer.framing import Framing, arms_origin
from amr_viewer.parameters import entries_from, value_of, visible
from amr_viewer.pending import Pending
from amr_viewer.state import Frames, RobotState, Skipped, WorldGoal, frontier_view, pose_graph_view
from amr_viewer.viewer_config import specs

NODE_NAME = "viewer"
TF_STATIC = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
STATUS_PERIOD = 1.0
"""s between two refreshes of the status panel (and node states)."""
RAW_KEEP = 64
"""Raw messages of a busy topic kept between two draws (a transform published every few steps is among them)."""
WARNING_PERIOD = 5.0


class RobotLink:
    """The subscriptions of one robot namespace feeding its RobotState; busy topics kept raw until drawn."""

    RAW_TOPICS = {  # leaf: (type, QoS, keep every message (a ring) or the latest only)
        "tf": (TFMessage, reliable(100), True),
        "tf_static": (TFMessage, TF_STATIC, True),
        "ground_truth": (Odometry, reliable(10), True),
        "scan": (LaserScan, SENSOR_DATA, False),
        "particle_cloud": (PoseArray, reliable(2), False),
        "pose": (LocalizedPose, reliable(10), False),
        "path": (Path, LATCHED, False),
        "beacons": (BeaconRanges, reliable(10), False),
        "map": (OccupancyGrid, LATCHED, False),
        "simulator/status": (SimulatorStatus, reliable(10), False),
        "slam/graph": (PoseGraph, LATCHED, False),  # the state as it is, to a viewer started late too
        "explorer/frontiers": (Frontiers, LATCHED, False),
    }
    LAYER = {"slam/graph": "graph", "explorer/frontiers": "frontiers"}
    """Leaf -> the RobotState layer it feeds, where the names differ."""

    def __init__(self, node: ViewerNode, namespace: str, graph: Collection[str]) -> None:
        self.node, self.namespace = node, namespace
        self.state = RobotState(
            namespace, node.frames, node.get_parameter("max_particles").value, node.get_parameter("trail_spacing").value
        )
        self.raw: dict[str, deque[bytes]] = {
            leaf: deque(maxlen=RAW_KEEP if ring else 1) for leaf, (_, _, ring) in self.RAW_TOPICS.items()
        }
        self.topics: dict[str, str] = {}
        """leaf -> the topic subscribed"""
        self._raw_subscriptions: dict[str, object] = {}
        self.deserialized = 0
        """fast-path messages that were not plain CDR, deserialized by rclpy instead (RobotLink._fast)."""
        self.refresh(graph)
        self._goal_subscription = node.create_subscription(
            PoseStamped, topics.join(namespace, "goal_pose"), self._on_goal, reliable(10)
        )

    @property
    def subscriptions(self) -> list:
        return [*self._raw_subscriptions.values(), self._goal_subscription]

    def topic_of(self, leaf: str, graph: Collection[str]) -> str:
        """The topic of `leaf` for this robot now (topics.leaf_topic)."""
        return topics.leaf_topic(self.namespace, leaf, graph, self.topics.get(leaf))

    def refresh(self, graph: Collection[str]) -> list[str]:
        """Subscribe each topic to what the graph now names (a fleet robot is often found by its filter's topics
        before its simulator publishes its own tf and status); returns the leaves resubscribed."""
        changed = []
        for leaf, (kind, qos, _) in self.RAW_TOPICS.items():
            topic = self.topic_of(leaf, graph)
            if self.topics.get(leaf) == topic:
                continue
            old = self._raw_subscriptions.pop(leaf, None)
            if old is not None:
                self.node.destroy_subscription(old)
                changed.append(leaf)
            buffer = self.raw[leaf]
            buffer.clear()
            self._raw_subscriptions[leaf] = self.node.create_subscription(
                kind, topic, lambda data, buffer=buffer: buffer.append(data), qos, raw=True
            )
            self.topics[leaf] = topic
        if {"tf", "tf_static"} & set(changed):
            self.state.tree.clear()  # the root's transforms are not this robot's
        return changed

    def _on_goal(self, message: PoseStamped) -> None:
        self.state.on_goal(messages.pose_of(message.pose))

    def decode(self) -> None:
        """Feed the raw messages kept since the last call to the state (one bad message is skipped, with a
        ValueError naming it raised at the end; a map, graph or frontiers in a wrong frame or with a non-finite
        value is counted in state.skipped and told to the node, which logs it once)."""
        state, problems = self.state, []
        for leaf, buffer in self.raw.items():
            while buffer:
                data = buffer.popleft()
                try:
                    self._feed(leaf, data)
                except Skipped as error:
                    layer = self.LAYER.get(leaf, leaf)
                    state.skipped[layer] += 1
                    self.node.report_skipped(self.namespace, layer, error)
                except Exception as error:  # a malformed message must not stop the view
                    problems.append(f"{leaf}: {type(error).__name__}: {error}")
        if problems:
            raise ValueError(f"{state.namespace or '/'}: " + "; ".join(problems))

    def _fast(self, leaf: str, data: bytes):
        """A fast-path leaf's plain data: read from its bytes where they are plain CDR (cdr.fast_path_applies), else
        deserialized by rclpy and converted to the same data (another encapsulation, XCDR2: counted in deserialized)."""
        read, convert = FAST[leaf]
        if cdr.fast_path_applies(data):
            return read(data)
        self.deserialized += 1
        return convert(deserialize_message(data, self.RAW_TOPICS[leaf][0]))

    def _feed(self, leaf: str, data: bytes) -> None:
        state = self.state
        if leaf in ("tf", "tf_static"):
            state.on_transforms(self._fast(leaf, data))
        elif leaf == "ground_truth":
            state.on_ground_truth(self._fast(leaf, data))
        elif leaf == "particle_cloud":
            state.on_particles(self._fast(leaf, data)[1])
        elif leaf == "map":
            grid = deserialize_message(data, OccupancyGrid)
            state.check_frame(grid.header.frame_id, "map")
            state.on_map(messages.occupancy_grid(grid), grid.header.frame_id)
        elif leaf == "slam/graph":
            graph = self._fast(leaf, data)
            state.check_frame(graph.header.frame_id, "pose graph")
            view = pose_graph_view(graph.poses, graph.edge_from, graph.edge_to, graph.loop_closure)
            state.on_graph(view, graph.header.frame_id)
        elif leaf == "explorer/frontiers":
            found = self._fast(leaf, data)
            state.check_frame(found.header.frame_id, "frontiers")
            view = frontier_view(found.centroids, found.sizes, found.chosen, found.blacklisted, found.state)
            state.on_frontiers(view, found.header.frame_id)
        else:
            convert, take = DECODED[leaf]
            getattr(state, take)(convert(deserialize_message(data, self.RAW_TOPICS[leaf][0])))


FAST = {
    "tf": (cdr.tf_message, messages.tf_transforms),
    "tf_static": (cdr.tf_message, messages.tf_transforms),
    "ground_truth": (cdr.odometry_pose, messages.odometry_transform),
    "particle_cloud": (cdr.pose_array, messages.pose_array),
    "slam/graph": (cdr.pose_graph, messages.pose_graph),
    "explorer/frontiers": (cdr.frontiers, messages.frontiers),
}
"""Leaf -> (its CDR reader, the converter of the message rclpy deserializes where the reader does not apply)."""

DECODED = {
    "scan": (messages.laser_scan, "on_scan"),
    "pose": (messages.localized_pose, "on_estimate"),
    "path": (messages.path_points, "on_path"),
    "beacons": (messages.beacon_positions, "on_beacons"),
    "simulator/status": (messages.simulator_status, "on_status"),
}
"""Leaf -> (converter to plain data, RobotState method) of the topics deserialized by rclpy (the others are decoded
straight from CDR, amr_viewer.cdr)."""


class ViewerNode(ManagedNode):
    """Wires the plain viewer classes to ROS and to viser (see the module docstring)."""

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(specs())
        self.server = self.scene = self.panels = None
        self.frames = Frames()
        self.robots: dict[str, RobotLink] = {}
        self.arms: dict[str, ArmSet] = {}
        self._arm_subscriptions: list = []
        self._arms_asked: set[str] = set()
        self._worlds_asked: set[str] = set()
        self.simulators: dict[str, dict[str, object]] = {}
        self.localizers: dict[str, object] = {}
        """Node -> client of its ~/reinitialize_global_localization: called before the simulator's reset."""
        self.node_states: dict[str, str] = {}
        self._state_clients: dict[str, object] = {}
        self._parameter_clients: dict[str, AsyncParameterClient] = {}
        self._parameter_entries: dict[str, dict] = {}
        self.clicks = ClickTool()
        self.click_namespace = ""
        self.pending = Pending()
        self._requests: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
        self._guard = None
        self._timers: list = []
        self.framing = Framing()
        self._last_status = 0.0
        self._graph: dict[str, set[str]] = {}
        """topic name -> its types, at the last look at the graph"""
        self._reported: set[tuple[str, str, str]] = set()
        """(namespace, layer, kind) of the messages not drawn that were logged (each once)"""
        self.paused: bool | None = None
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._pose_publishers: dict[str, object] = {}

    # -- lifecycle ------------------------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if problems:
            return self.fail_configure(problems)
        values = self.parameter_values()
        self.frames = Frames(values["map_frame"], values["odom_frame"], values["base_frame"])
        try:
            self._start_server(values["host"], values["port"])
        except (OSError, ValueError) as error:
            return self.fail_configure([f"web server on {values['host']}:{values['port']}: {error}"])
        self._guard = self.create_guard_condition(self._run_requests)
        return TransitionCallbackReturn.SUCCESS

    def _start_server(self, host: str, port: int) -> None:
        import viser  # here: a node that is never configured does not pay for the web server

        from amr_viewer.panels import Panels
        from amr_viewer.scene import Scene

        with contextlib.redirect_stdout(io.StringIO()):  # viser's banner: the log line below says it
            server = viser.ViserServer(host=host, port=port, label="amr_viewer", verbose=False)
        if port and server.get_port() != port:  # viser moves on to the next free port: say so instead
            server.stop()
            raise OSError(f"port {port} is in use")
        server.request_share_url = refuse_share_url  # no tunnel to a public relay, whatever a page asks
        self.server = server
        self.scene = Scene(server, self.get_parameter("robot_radius").value)
        self.panels = Panels(server, self)
        server.scene.on_click()(lambda event: self.request(lambda: self._on_floor_click(event)))
        server.on_client_connect(lambda client: self.request(lambda: self._frame_new_client(client)))
        self.get_logger().info(
            f"viewer at {self.url} (no authentication: anyone who reaches this address can drive the robot)"
        )

    @property
    def url(self) -> str:
        return f"http://{self.server.get_host()}:{self.server.get_port()}" if self.server else ""

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        result = super().on_activate(state)
        self._start_timers(self.get_parameter("discovery_period").value, self.get_parameter("draw_period").value)
        self._guarded(self._discover)()
        return result

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._stop_timers()
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._release()
        return super().on_cleanup(state)  # and whatever else configure made

    def on_shutdown(self, state: State) -> TransitionCallbackReturn:
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self) -> None:
        self._release()
        super().destroy_node()

    def _start_timers(self, discovery_period: float, draw_period: float) -> None:
        self._stop_timers()
        self._timers = [
            self.create_timer(discovery_period, self._guarded(self._discover), clock=self._steady),
            self.create_timer(draw_period, self._guarded(self._draw), clock=self._steady),
        ]

    def _stop_timers(self) -> None:
        for timer in self._timers:
            self.destroy_timer(timer)
        self._timers = []

    def _release(self) -> None:
        """Stop drawing and serving; forget the graph (safe on a half-built node, and twice)."""
        self._stop_timers()
        for link in self.robots.values():
            for subscription in link.subscriptions:
                self.destroy_subscription(subscription)
        for subscription in self._arm_subscriptions:
            self.destroy_subscription(subscription)
        for client in list(self.clients):  # simulator controls, node states, parameter services
            self.destroy_client(client)
        for publisher in self._pose_publishers.values():
            self.destroy_publisher(publisher)
        if self._guard is not None:
            self.destroy_guard_condition(self._guard)
        self.robots, self.arms, self._arm_subscriptions, self._pose_publishers, self._guard = {}, {}, [], {}, None
        self._arms_asked, self._worlds_asked, self.simulators, self.localizers = set(), set(), {}, {}
        self._state_clients, self._parameter_clients, self.node_states = {}, {}, {}
        self._reported = set()
        self.framing.top_views.clear()  # (the browsers framed are kept, as before the move)
        if self.server is not None:
            self.server.stop()
        self.server = self.scene = self.panels = None

    def apply_live(self, changes: dict) -> None:
        """Periods and the particle budget, from the next tick."""
        if "max_particles" in changes:
            for link in self.robots.values():
                link.state.max_particles = changes["max_particles"]
        if {"draw_period", "discovery_period"} & set(changes) and self._timers:
            periods = {
                "discovery_period": self.get_parameter("discovery_period").value,
                "draw_period": self.get_parameter("draw_period").value,
                **changes,
            }
            self._start_timers(periods["discovery_period"], periods["draw_period"])

    # -- requests from the page (viser threads) -> this node's executor -----------------------------------------

    def request(self, work: Callable[[], None]) -> None:
        """Run `work` on the executor (thread-safe; called from viser's threads)."""
        self._requests.put(work)
        if self._guard is not None:
            self._guard.trigger()

    def _run_requests(self) -> None:
        while True:
            try:
                work = self._requests.get_nowait()
            except queue.Empty:
                return
            self._guarded(work)()

    def _guarded(self, work: Callable[[], None]) -> Callable[[], None]:
        def call() -> None:
            try:
                work()
            except Exception as error:  # nothing escapes a callback
                self.get_logger().error(
                    f"{getattr(work, '__name__', 'request')}: {type(error).__name__}: {error}",
                    throttle_duration_sec=WARNING_PERIOD,
                )

        return call

    # Actions (amr_viewer.panels): each queued for the executor.

    def control(self, service: str) -> None:
        self.request(lambda: self._control(service))

    def set_pace(self, pace: float) -> None:
        self.request(lambda: self._set_simulator_parameter("pace", pace))

    def set_click_mode(self, mode: str, two_clicks: bool, robot: str) -> None:
        def apply() -> None:
            self.clicks.set_mode(mode)
            self.clicks.set_two_clicks(two_clicks)
            self.click_namespace = "" if robot in ("/", "(none yet)") else robot

        self.request(apply)

    def frame(self, client, view: str) -> None:
        self.request(lambda: self._frame(client, view))

    def select_node(self, node: str) -> None:
        self.request(lambda: self._load_parameters(node))

    def set_parameter(self, node: str, entry, value) -> None:
        self.request(lambda: self._set_parameter(node, entry, value))

    def hide_layer(self, layer: str, hidden: bool) -> None:
        self.request(lambda: self.scene.set_hidden(layer, hidden))

    # -- the graph --------------------------------------------------------------------------------------------

    def _discover(self) -> None:
        graph_topics = self.get_topic_names_and_types()
        services = self.get_service_names_and_types()
        self._graph = {name: set(types) for name, types in graph_topics}
        wanted = set(self.get_parameter("namespaces").value)
        for link in self.robots.values():
            for leaf in link.refresh(self._graph):
                self.get_logger().info(f"robot {link.namespace or '/'}: {leaf} from {link.topics[leaf]}")
        for namespace in topics.robot_namespaces(graph_topics):
            if namespace not in self.robots and (not wanted or (namespace or "/") in wanted):
                self.robots[namespace] = RobotLink(self, namespace, self._graph)
                self.get_logger().info(f"drawing robot {namespace or '/'}")
        self.panels.set_robots([link.state.namespace or "/" for link in self.robots.values()])
        for simulator in topics.simulators(services):
            if simulator not in self.simulators:
                self.simulators[simulator] = {
                    name: self.create_client(Trigger, f"{simulator}/{name}") for name in topics.CONTROL_SERVICES
                }
            self._ask_world(simulator)
        for localizer in topics.localizers(services):
            if localizer not in self.localizers:
                self.localizers[localizer] = self.create_client(Empty, f"{localizer}/{topics.GLOBAL_LOCALIZATION}")
        for node in topics.joint_state_nodes(graph_topics):
            self._ask_arms(node)
        for node in topics.lifecycle_nodes(services):
            if node not in self._state_clients and node != self.get_fully_qualified_name():
                self._state_clients[node] = self.create_client(GetState, f"{node}/get_state")
        own = self.get_fully_qualified_name()
        nodes = sorted(
            topics.full_name(name, namespace)
            for name, namespace in self.get_node_names_and_namespaces()
            if not name.startswith("_")
        )
        self.panels.set_nodes([node for node in nodes if node != own])

    def _parameters_client(self, node: str) -> AsyncParameterClient:
        if node not in self._parameter_clients:
            self._parameter_clients[node] = AsyncParameterClient(self, node)
        return self._parameter_clients[node]

    def _ask_world(self, simulator: str) -> None:
        """The world's goal and beacons and the robot's radius, from the simulator's parameters (once)."""
        client = self._parameters_client(simulator)
        if simulator in self._worlds_asked or not client.services_are_ready():
            return
        self._worlds_asked.add(simulator)
        namespace = topics.split(simulator)[0]

        def answered(response) -> None:
            if isinstance(response, Exception) or len(response.values) != 2:
                return
            world_name, radius = (value_of(v) for v in response.values)
            if isinstance(radius, float) and self.scene is not None:
                self.scene.robot_radius = radius
            link = self.robots.get(namespace)
            if link is None or not isinstance(world_name, str):
                self._worlds_asked.discard(simulator)  # the robot is not seen yet: ask again
                return
            world = load_world(resolve_world_path(world_name))
            goal = WorldGoal(world.goal.x, world.goal.y, world.goal.radius) if world.goal is not None else None
            link.state.on_world(goal, world.beacons)

        self.pending.add(
            client.get_parameters(["world", "robot.radius"]), answered, lambda: self._worlds_asked.discard(simulator)
        )

    def _ask_arms(self, node: str) -> None:
        """An IK service's chains from its parameters, then its joint states (once)."""
        client = self._parameters_client(node)
        if node in self._arms_asked or not client.services_are_ready():
            return
        self._arms_asked.add(node)

        def listed(response) -> None:
            if isinstance(response, Exception):
                self._arms_asked.discard(node)
                return
            names = list(response.result.names)
            if "chains" not in names:
                return  # not an IK service
            self.pending.add(
                client.get_parameters(names), lambda answer: got(names, answer), lambda: self._arms_asked.discard(node)
            )

        def got(names, response) -> None:
            if isinstance(response, Exception) or len(response.values) != len(names):  # one undeclared or unset
                self._arms_asked.discard(node)
                return
            values = {name: value_of(value) for name, value in zip(names, response.values, strict=True)}
            arms = ArmSet.from_parameters(values, arms_origin(link.state.extent() for link in self.robots.values()))
            self.arms[node] = arms
            self._arm_subscriptions.append(
                self.create_subscription(
                    JointState,
                    f"{node}/joint_states",
                    lambda message: self._on_joint_state(node, message),
                    reliable(10),
                )
            )
            self.get_logger().info(f"drawing the arms of {node}: {', '.join(arms.arms)}")
            self._frame_all("arms" if not self.robots else "top")

        self.pending.add(client.list_parameters(), listed, lambda: self._arms_asked.discard(node))

    def _on_joint_state(self, node: str, message: JointState) -> None:
        arms = self.arms.get(node)
        if arms is not None:
            arms.on_joint_state(list(message.name), list(message.position))

    # -- drawing ----------------------------------------------------------------------------------------------

    def report_skipped(self, namespace: str, layer: str, error: Skipped) -> None:
        """A message not drawn (a wrong frame, a non-finite value): logged the first time for each robot, layer and
        reason; the status panel counts them."""
        key = (namespace, layer, error.kind)
        if key not in self._reported:
            self._reported.add(key)
            self.get_logger().warning(
                f"robot {namespace or '/'}: {error} (skipped; said once, later ones are counted in the status panel)"
            )

    def _draw(self) -> None:
        self.pending.poll()
        drawing = bool(self.server.get_clients())
        for link in self.robots.values():
            try:
                link.decode()
            except ValueError as error:
                self.get_logger().warning(f"a message was not drawn: {error}", throttle_duration_sec=WARNING_PERIOD)
        if drawing:
            with self.server.atomic():  # one redraw per tick in the browser, not one per layer
                for link in self.robots.values():
                    self.scene.draw(link.state)
                for key, arms in self.arms.items():
                    self.scene.draw_arms(arms, "arms" + key.replace("/", "_"))
            for client_id, client in self.server.get_clients().items():
                if client_id not in self.framing.framed:  # nothing to frame when it connected
                    self._frame(client, "top" if self.robots else "arms")
                else:
                    self._follow_growth(client)
        now = time.monotonic()
        if now - self._last_status >= STATUS_PERIOD:
            self._last_status = now
            self._refresh_status()

    def _frame_new_client(self, client) -> None:
        self._frame(client, "top" if self.robots else "arms")

    def _frame_all(self, view: str) -> None:
        for client in self.server.get_clients().values():
            self._frame(client, view)

    def _frame(self, client, view: str) -> None:
        """Point a browser's camera at the robots (top-down) or at the arms; nothing until there is something."""
        if client is None:
            return
        camera = self.framing.camera(
            client.client_id,
            view,
            robots=[link.state.extent() for link in self.robots.values()],
            arms=[arms.bounds() for arms in self.arms.values()],
            screen=lambda: (client.camera.aspect, client.camera.image_width),
        )
        if camera is not None:
            client.camera.fov = camera.fov
            client.camera.position = camera.position
            client.camera.look_at = camera.look_at

    def _follow_growth(self, client) -> bool:
        """Frame the top view again when the robots' maps have grown out of it or the browser's canvas changed, and
        the user has not moved the camera since it was set (Framing.stale); True when it was framed again."""
        maps = [link.state.map.bounds for link in self.robots.values() if link.state.map is not None]
        if not self.framing.stale(
            client.client_id,
            lambda: (client.camera.position, client.camera.look_at),
            maps,
            lambda: (client.camera.aspect, client.camera.image_width),
        ):
            return False
        self._frame(client, "top")
        return True

    # -- status -----------------------------------------------------------------------------------------------

    def _refresh_status(self) -> None:
        for node, client in self._state_clients.items():
            if client.service_is_ready():
                self.pending.add(
                    client.call_async(GetState.Request()),
                    lambda answer, node=node: self._set_node_state(node, answer),
                    lambda node=node: self._set_node_state(node, None),
                )
        robots = [
            status.robot_line(link.state, self.scene.color_name_of(link.state.namespace))
            for link in self.robots.values()
        ]
        arms = {node: list(arms.arms) for node, arms in self.arms.items()}
        self.panels.status.content = status.panel_text(self.node_states, self.paused, robots, arms)

    def _set_node_state(self, node: str, answer) -> None:
        self.node_states[node] = (
            "no answer" if answer is None or isinstance(answer, Exception) else answer.current_state.label
        )

    # -- simulator controls -----------------------------------------------------------------------------------

    def _control(self, service: str) -> None:
        if not self.simulators:
            self.panels.simulation_reply.content = replies.NO_SIMULATOR
            return
        localizers = [node for node, client in self.localizers.items() if client.service_is_ready()]
        if service != "reset" or not localizers:
            self._call_simulators(service)
            return
        # a reset first restarts each localizer's global localization (replies.Countdown)
        countdown = replies.Countdown(
            localizers, lambda: self._call_simulators(service, replies.restart_note(localizers))
        )
        for node in localizers:
            self.pending.add(
                self.localizers[node].call_async(Empty.Request()),
                lambda answer, node=node: countdown.done(node),
                lambda node=node: countdown.done(node),
            )

    def _call_simulators(self, service: str, note: str = "") -> None:
        """Each simulator's ~/<service>; its answer (and `note` after a success) under the buttons."""
        for simulator, clients in self.simulators.items():
            client = clients[service]
            if not client.service_is_ready():
                self.panels.simulation_reply.content = f"{simulator}/{service} is not ready"
                continue

            def answered(response, simulator=simulator) -> None:
                text, paused = replies.control_reply(simulator, service, response, note)
                if paused is not None:
                    self.paused = paused
                self.panels.simulation_reply.content = text

            self.pending.add(
                client.call_async(Trigger.Request()),
                answered,
                lambda simulator=simulator: setattr(
                    self.panels.simulation_reply, "content", f"{simulator}/{service}: no answer"
                ),
            )

    def _set_simulator_parameter(self, name: str, value) -> None:
        for simulator in self.simulators:

            def answered(response, simulator=simulator) -> None:
                self.panels.simulation_reply.content = replies.simulator_parameter_reply(
                    simulator, name, value, response
                )

            self.pending.add(
                self._parameters_client(simulator).set_parameters([Parameter(name, value=value)]),
                answered,
                lambda: None,
            )

    # -- clicks on the floor ----------------------------------------------------------------------------------

    def _on_floor_click(self, event) -> None:
        link = self.robots.get(self.click_namespace) or next(iter(self.robots.values()), None)
        robot = link.state.robot_pose if link is not None else lambda: None
        chosen, said = self.clicks.ray(event.ray_origin, event.ray_direction, robot)
        if said is not None:
            self.panels.click_reply.content = said
        if chosen is None:
            return
        mode, pose = chosen
        self.send_pose(mode, pose, link.state.namespace if link is not None else "")

    def send_pose(self, mode: str, pose: Pose2D, namespace: str = "") -> None:
        """Publish a goal (/goal_pose) or a pose estimate (/initialpose) in the map frame, in `namespace`."""
        stamp = self.get_clock().now().to_msg()
        if mode == GOAL:
            message = messages.fill_pose_stamped(PoseStamped(), self.frames.map, stamp, pose)
        else:
            message = messages.fill_initial_pose(PoseWithCovarianceStamped(), self.frames.map, stamp, pose)
        topic = pose_topic(mode, namespace)
        if topic not in self._pose_publishers:
            self._pose_publishers[topic] = self.create_publisher(type(message), topic, reliable(10))
        self._pose_publishers[topic].publish(message)
        self.panels.click_reply.content = sent_text(topic, pose)

    # -- the parameters panel ---------------------------------------------------------------------------------

    def _load_parameters(self, node: str) -> None:
        client = self._parameters_client(node)
        reply = self.panels.parameter_reply
        if not client.services_are_ready():
            reply.content = f"{node}'s parameter services are not ready; try Reload"
            return
        reply.content = f"asking {node} ..."

        def listed(response) -> None:
            if isinstance(response, Exception):
                reply.content = f"{node}: {response}"
                return
            names = sorted(name for name in response.result.names if visible(name))
            self.pending.add(
                client.describe_parameters(names),
                lambda described: got_descriptors(names, described),
                lambda: setattr(reply, "content", f"{node}: no answer"),
            )

        def got_descriptors(names, described) -> None:
            if isinstance(described, Exception):
                reply.content = f"{node}: {described}"
                return
            self.pending.add(
                client.get_parameters(names),
                lambda values: got_values(names, described.descriptors, values),
                lambda: setattr(reply, "content", f"{node}: no answer"),
            )

        def got_values(names, descriptors, values) -> None:
            if isinstance(values, Exception):
                reply.content = f"{node}: {values}"
                return
            entries = entries_from(names, descriptors, values.values)
            if entries is None:
                reply.content = f"{node}: no values for {len(names)} parameters (one undeclared or unset); try Reload"
                return
            self._parameter_entries[node] = {entry.name: entry for entry in entries}
            self.panels.show_parameters(node, entries)
            reply.content = f"{node}: {len(entries)} parameters"

        self.pending.add(client.list_parameters(), listed, lambda: setattr(reply, "content", f"{node}: no answer"))

    def _set_parameter(self, node: str, entry, given) -> None:
        reply = self.panels.parameter_reply
        try:
            value = entry.parse(given)
        except ValueError as error:
            reply.content = str(error)
            self.panels.show_value(node, entry, entry.value)
            return
        client = self._parameters_client(node)

        def answered(response) -> None:
            taken = replies.taken(response)
            if taken:
                entry.value = value
            reply.content = replies.parameter_reply(node, entry.name, value, entry.text(), response)
            if not taken:
                self.panels.show_value(node, entry, entry.value)

        self.pending.add(
            client.set_parameters([entry.message(value)]),
            answered,
            lambda: setattr(reply, "content", f"{node}: no answer to setting {entry.name}"),
        )


def refuse_share_url(*args, **kwargs) -> None:
    """viser's page can ask for a public share URL (a tunnel through viser's relay); the viewer never makes one."""
    return None


def main(args=None) -> None:
    run(ViewerNode, args=args)


if __name__ == "__main__":
    main()
