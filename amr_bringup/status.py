"""`amr-bringup --status`: the lifecycle state of each managed node and the rate of each topic the stack publishes.

For people without the ROS command-line tools. The topics are discovered from the graph
(the publishers of the stack's nodes) and subscribed to generically: the type comes
from the graph as `pkg/msg/Type` and its class from `importlib.import_module("pkg.msg")`;
messages are taken raw (no deserialization) since only their arrival counts.
"""

from __future__ import annotations

import importlib
import threading
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

from lifecycle_msgs.srv import GetState
from rclpy.node import Node, NodeNameNonExistentError
from rclpy.qos import qos_profile_sensor_data

RATE_WINDOW = 2.0
"""s of arrivals over which a topic's rate is measured."""
IGNORED_TOPICS = ("/rosout", "/parameter_events")
IGNORED_SUFFIXES = ("/transition_event",)


@dataclass(frozen=True)
class TopicRow:
    topic: str
    type_name: str
    rate: float | None  # Hz; None when the type cannot be imported here
    publishers: tuple[str, ...]


def message_class(type_name: str):
    """`geometry_msgs/msg/Twist` -> the class geometry_msgs.msg.Twist (ImportError/AttributeError if absent)."""
    package, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def format_table(title: str, states: Sequence[tuple[str, str]], topics: Sequence[TopicRow]) -> str:
    """The status as fixed-width text: one block of nodes, one of topics."""
    width = max([len("NODE")] + [len(name) for name, _ in states])
    lines = [title, f"{'NODE':<{width}}  STATE"]
    lines += [f"{name:<{width}}  {state}" for name, state in states]
    topic_width = max([len("TOPIC")] + [len(row.topic) for row in topics])
    type_width = max([len("TYPE")] + [len(row.type_name) for row in topics])
    lines += ["", f"{'TOPIC':<{topic_width}}  {'TYPE':<{type_width}}  {'RATE (Hz)':>9}  PUBLISHERS"]
    for row in topics:
        rate = "?" if row.rate is None else f"{row.rate:.1f}"
        publishers = ", ".join(row.publishers)
        lines.append(f"{row.topic:<{topic_width}}  {row.type_name:<{type_width}}  {rate:>9}  {publishers}")
    if not topics:
        lines.append("(no topic published by the stack yet)")
    return "\n".join(lines)


class StatusMonitor(Node):
    """Asks each managed node for its state and counts the messages of the stack's topics; `refresh()` once a period."""

    def __init__(self, managed: Sequence[str], stack: Sequence[tuple[str, str]], **kwargs) -> None:
        """managed: names for /<name>/get_state; stack: (name, namespace) of every node whose publishers count."""
        super().__init__("amr_bringup_status", **kwargs)
        self._managed, self._stack = list(managed), list(stack)
        self._lock = threading.Lock()
        self._states = {name: "unknown" for name in self._managed}
        self._state_clients = {name: self.create_client(GetState, f"{name}/get_state") for name in self._managed}
        self._arrivals: dict[str, deque[float]] = {}
        self._subscribed_at: dict[str, float] = {}
        self._types: dict[str, str] = {}
        self._topic_publishers: dict[str, set[str]] = {}
        self._unimportable: set[str] = set()

    def refresh(self) -> None:
        """Ask for the states again and subscribe to any topic the stack has started publishing."""
        for name, client in self._state_clients.items():
            if client.service_is_ready():
                client.call_async(GetState.Request()).add_done_callback(
                    lambda future, name=name: self._set_state(name, future)
                )
            else:
                self._set_state(name, None)
        for node_name, namespace in self._stack:
            try:
                published = self.get_publisher_names_and_types_by_node(node_name, namespace or "/")
            except NodeNameNonExistentError:  # not discovered yet, or gone
                continue
            for topic, types in published:
                if topic in IGNORED_TOPICS or topic.endswith(IGNORED_SUFFIXES) or not types:
                    continue
                with self._lock:
                    self._topic_publishers.setdefault(topic, set()).add(node_name)
                self._subscribe(topic, types[0])

    def _set_state(self, name: str, future) -> None:
        label = "unknown"
        if future is not None:
            answer = None if future.exception() else future.result()
            label = "no answer" if answer is None else answer.current_state.label
        elif name in self._states and self._states[name] != "unknown":
            label = "gone"
        with self._lock:
            self._states[name] = label

    def _subscribe(self, topic: str, type_name: str) -> None:
        if topic in self._types:
            return
        self._types[topic] = type_name
        try:
            kind = message_class(type_name)
        except (ImportError, AttributeError, ValueError):
            self._unimportable.add(topic)
            return
        with self._lock:
            self._arrivals[topic] = deque()
            self._subscribed_at[topic] = time.monotonic()
        self.create_subscription(
            kind, topic, lambda _, topic=topic: self._count(topic), qos_profile_sensor_data, raw=True
        )

    def _count(self, topic: str) -> None:
        with self._lock:
            self._arrivals[topic].append(time.monotonic())

    def snapshot(self) -> tuple[list[tuple[str, str]], list[TopicRow]]:
        """(node, state) for the managed nodes and a row per topic, sorted by topic."""
        now = time.monotonic()
        rows = []
        with self._lock:
            states = [(name, self._states[name]) for name in self._managed]
            for topic in sorted(self._types):
                rate = None
                if topic not in self._unimportable:
                    arrivals = self._arrivals[topic]
                    while arrivals and arrivals[0] < now - RATE_WINDOW:
                        arrivals.popleft()
                    span = min(RATE_WINDOW, now - self._subscribed_at[topic])
                    rate = len(arrivals) / span if span > 0 else 0.0
                rows.append(TopicRow(topic, self._types[topic], rate, tuple(sorted(self._topic_publishers[topic]))))
        return states, rows
