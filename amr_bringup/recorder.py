"""recorder: topics into a rosbag2 MCAP bag (`ros2 run amr_bringup recorder --ros-args -p path:=out/run.mcap`).

What `ros2 bag record -s mcap` does, for machines without rosbag2: every topic of the graph (or the
ones in `topics`) is found by discovery, subscribed to raw (no deserialization) with a QoS that
matches all its publishers (reliable only if every publisher is, transient local only if every
publisher is, as rosbag2 adapts it), and written with amr_bringup.bag_writer together with its type,
definition and the offered QoS. Each message is stamped with this node's clock when it arrives
(simulated time under use_sim_time, as `ros2 bag record --use-sim-time`). Topics that appear later
are picked up every `discovery_period`. The bag is finished (metadata.yaml written) when the node is
destroyed: Ctrl-C, SIGTERM, or the end of amr-bringup. `~/caught_up` (std_srvs/Trigger) answers
success once every eligible topic with publishers is recorded and matched with all of them: amr-bringup
--record activates each node only then, so a lockstep run is recorded from its first step.
"""

from __future__ import annotations

import sys
import threading
import time

import rclpy
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from std_srvs.srv import Trigger

from amr_bringup.bag_writer import BagError, BagWriter, TopicQos
from amr_bringup.recording import recorded_by_default
from amr_bringup.status import message_class
from amr_util.executors import executor_for
from amr_util.managed_node import SpecifiedParameters, spin_nodes
from amr_util.parameter_spec import ParameterSpec

PARAMETERS = (
    ParameterSpec(
        "path",
        "",
        "the bag to write: out/run.mcap (or out/run) makes the rosbag2 directory out/run; it must not exist yet",
        read_only=True,
    ),
    ParameterSpec(
        "topics",
        [""],
        "topics to record; [] or [''] = every topic (but /rosout, /parameter_events and lifecycle transition events)",
        kind="str_array",
        read_only=True,
    ),
    ParameterSpec(
        "discovery_period", 0.1, "wall-clock s between looks for new topics", minimum=0.01, maximum=60.0, read_only=True
    ),
    ParameterSpec(
        "queue_depth",
        1000,
        "messages a subscription holds while the bag writer is busy (reliable "
        "publishers with a shallow history lose nothing while the recorder keeps within it)",
        minimum=1,
        maximum=100000,
        read_only=True,
    ),
)

CATCH_UP_TIMEOUT = 3.0
"""s a startup waits for the recorder to subscribe to a node's topics before activating it."""
MATCH_SETTLE = 0.05
"""s after the match is seen: the writer side learns of the new reader a moment after the reader sees it."""


def offered_depth(profiles) -> int | None:
    """The history depth every publisher offers, or None (unknown) when discovery does not tell it, which
    is always the case for DDS (a depth-10 publisher is reported as history UNKNOWN, depth 0): the bag
    then says so, as rosbag2's does, instead of a depth nobody offered."""
    if profiles and all(p.history == HistoryPolicy.KEEP_LAST and p.depth > 0 for p in profiles):
        return max(p.depth for p in profiles)
    return None


class Recorder(SpecifiedParameters, Node):
    """Parameters: path, topics, discovery_period, queue_depth. Raises ValueError naming bad parameters, BagError."""

    def __init__(self, **kwargs) -> None:
        super().__init__("recorder", **kwargs)
        self.use_parameter_specs()
        self.declare_specs(PARAMETERS)
        problems = self.parameter_problems()
        if not self.get_parameter("path").value:
            problems.append("path: required (the bag to write, e.g. out/run.mcap)")
        if problems:
            self.destroy_node()
            raise ValueError("; ".join(problems))
        self.wanted = frozenset(t for t in self.get_parameter("topics").value if t)
        self._depth = self.get_parameter("queue_depth").value
        self._lock = threading.Lock()
        self._discovering = threading.Lock()  # the timer and a startup's wait both discover
        self._group = MutuallyExclusiveCallbackGroup()  # one writer: callbacks never overlap
        self._subscriptions_by_topic: dict[str, object] = {}
        self._skipped: set[str] = set()
        self.counts: dict[str, int] = {}
        try:
            self._writer: BagWriter | None = BagWriter(self.get_parameter("path").value)
        except (BagError, OSError) as error:
            self.destroy_node()
            raise ValueError(f"path: {error}") from error
        self.path = self._writer.path
        self.discover()
        self.create_service(Trigger, "~/caught_up", self._on_caught_up, callback_group=self._group)
        self._timer = self.create_timer(
            self.get_parameter("discovery_period").value,
            self.discover,
            callback_group=self._group,
            clock=Clock(clock_type=ClockType.STEADY_TIME),
        )
        self.get_logger().info(f"recording {'every topic' if not self.wanted else sorted(self.wanted)} to {self.path}")

    def eligible(self, topic: str) -> bool:
        if self.wanted:
            return topic in self.wanted
        return recorded_by_default(topic)

    def discover(self) -> None:
        """Subscribe to every eligible topic that has publishers and is not recorded yet."""
        with self._discovering:
            if self._writer is None:
                return
            for topic, types in self.get_topic_names_and_types():
                if topic in self._subscriptions_by_topic or topic in self._skipped or not self.eligible(topic):
                    continue
                publishers = self.get_publishers_info_by_topic(topic)
                if publishers and types:
                    self._record(topic, types[0], publishers)

    def caught_up(self) -> bool:
        """Every eligible topic with publishers is recorded, and matched with all of them (a startup waits on this)."""
        self.discover()
        for topic, _ in self.get_topic_names_and_types():
            if not self.eligible(topic) or topic in self._skipped:
                continue
            publishers = len(self.get_publishers_info_by_topic(topic))
            subscription = self._subscriptions_by_topic.get(topic)
            if publishers and (subscription is None or subscription.get_publisher_count() < publishers):
                return False
        return True

    def _on_caught_up(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success = self.caught_up()
        response.message = f"recording {len(self._subscriptions_by_topic)} topics"
        return response

    def wait_until_caught_up(self, timeout: float = CATCH_UP_TIMEOUT) -> bool:
        """Block (another thread spins this node) until caught_up(), at most `timeout` s, then let matching settle."""
        deadline = time.monotonic() + timeout
        while not self.caught_up():
            if time.monotonic() > deadline:
                return False
            time.sleep(0.01)
        time.sleep(MATCH_SETTLE)
        return True

    def _record(self, topic: str, type_name: str, publishers) -> None:
        profiles = [info.qos_profile for info in publishers]
        reliable = all(p.reliability == ReliabilityPolicy.RELIABLE for p in profiles)
        latched = all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in profiles)
        try:
            kind = message_class(type_name)
            self._writer.add_topic(topic, type_name, TopicQos(reliable, latched, offered_depth(profiles)))
        except (ImportError, AttributeError, ValueError) as error:  # BagError is a ValueError
            self._skipped.add(topic)
            self.get_logger().warning(f"not recording {topic} ({type_name}): {error}")
            return
        qos = QoSProfile(
            depth=self._depth,
            reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
        )
        self.counts[topic] = 0
        self._subscriptions_by_topic[topic] = self.create_subscription(
            kind, topic, lambda data, topic=topic: self._write(topic, data), qos, raw=True, callback_group=self._group
        )

    def _write(self, topic: str, data: bytes) -> None:
        with self._lock:
            if self._writer is None:
                return
            try:
                self._writer.write(topic, self.get_clock().now().nanoseconds, data)
                self.counts[topic] += 1
            except Exception as error:  # a full disk: say so, keep the node alive
                self.get_logger().error(
                    f"{topic}: write failed: {type(error).__name__}: {error}", throttle_duration_sec=5.0
                )

    def close(self) -> None:
        """Stop recording and finish the bag (metadata.yaml); safe to call twice."""
        with self._lock:
            writer, self._writer = self._writer, None
        if writer is None:
            return
        for subscription in self._subscriptions_by_topic.values():
            self.destroy_subscription(subscription)
        writer.close()
        self.get_logger().info(f"wrote {writer.messages} messages of {len(self.counts)} topics to {self.path}")

    def destroy_node(self) -> None:
        if getattr(self, "_writer", None) is not None:
            self.close()
        super().destroy_node()


class BackgroundSpin:
    """A recorder spun apart from the stack it records, on an executor of its own (amr_util.executors') in a daemon
    thread: its subscriptions stay out of the stack's wait set, which every step of a composed lockstep loop
    would otherwise rebuild with them. stop() destroys the node, which finishes the bag."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.executor = executor_for(node, node.context)
        self.executor.add_node(node)
        self._thread = threading.Thread(target=self.executor.spin, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self.executor.shutdown(timeout_sec=5.0)
        self._thread.join(timeout=5.0)
        self.node.destroy_node()


def main(args=None) -> None:
    rclpy.init(args=sys.argv if args is None else args, signal_handler_options=SignalHandlerOptions.NO)
    try:
        recorder = Recorder()
    except ValueError as error:
        print(f"recorder: {error}", file=sys.stderr)
        rclpy.shutdown()
        raise SystemExit(2) from None
    spin_nodes([recorder], executor_for(recorder))


if __name__ == "__main__":
    main()
