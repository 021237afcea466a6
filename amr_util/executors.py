"""Several nodes in one process, each spun by an executor and a thread of its own.

Measured on maze_sim composed (map_server, simulator, wall follower, lifecycle manager; lockstep):
one MultiThreadedExecutor(4) over all nodes ran 0.5x real time, one SingleThreadedExecutor 16x,
and one SingleThreadedExecutor per node 12x. rclpy's MultiThreadedExecutor rebuilds one big wait set
and hands every ready callback to its pool through futures; the lockstep loop waits on that hand-off
at every step. One executor per node keeps the nodes independent (a blocking service call in the
lifecycle manager, or a long solve in the IK service, stops no other node) at almost the speed of a
single executor. A node whose callbacks must overlap (a reentrant group) says so with the class
attribute `multithreaded_executor = True` and gets a MultiThreadedExecutor of its own.

One /clock subscription serves every node of the process (`share_clock`, on by default): each node with
use_sim_time subscribed to /clock and woke for every message of it, a quarter of a fleet's wake-ups. The first such
node added makes a hidden node (CLOCK_NODE) with one TimeSource on a thread of its own, and every node's clock is
attached to it (a TimeSource updates every clock attached to it) in place of the node's own /clock subscription.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from rclpy.executors import Executor, ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.time import Time
from rclpy.time_source import TimeSource

CLOCK_NODE = "_composed_clock"
"""The hidden node whose one /clock subscription feeds every composed node's clock (share_clock)."""


class SharedTimeSource(TimeSource):
    """rclpy's TimeSource, its clocks updated from a snapshot of them: a node attached from another thread while a
    /clock message is handled does not break the loop over the clocks (it gets the next message's time)."""

    def clock_callback(self, msg) -> None:
        time = Time.from_msg(msg.clock)
        self._last_time_set = time
        for clock in tuple(self._associated_clocks):  # copied under the GIL in one C call
            clock.set_ros_time_override(time)


class NodeSpinners:
    """add_node() starts spinning a node at once; shutdown() stops every spinner (the nodes stay, for the caller
    to destroy). An exception out of a callback stops that node's spinner and is passed to `on_error`."""

    def __init__(
        self,
        context=None,
        on_error: Callable[[BaseException], None] = lambda error: None,
        *,
        share_clock: bool = True,
    ) -> None:
        self._context = context
        self._on_error = on_error
        self._spinners: list[tuple[Node, Executor, threading.Thread]] = []
        self._share_clock = share_clock
        self._clock: tuple[Node, SharedTimeSource, Executor, threading.Thread] | None = None

    def add_node(self, node: Node) -> None:
        if self._share_clock:
            self._attach_clock(node)
        if getattr(node, "multithreaded_executor", False):
            executor: Executor = MultiThreadedExecutor(context=self._context)
        else:
            executor = SingleThreadedExecutor(context=self._context)
        executor.add_node(node)
        thread = threading.Thread(target=self._spin, args=(executor,), name=f"spin {node.get_name()}", daemon=True)
        self._spinners.append((node, executor, thread))
        thread.start()

    def _attach_clock(self, node: Node) -> None:
        """A node on simulated time gets its clock from the shared time source, not its own /clock subscription.
        rclpy 7.1.6 keeps the subscription in the node's TimeSource (`_time_source._clock_sub`): it is destroyed here,
        and the node's TimeSource stays attached to its parameters (use_sim_time set false, then true, subscribes
        again: the clock is then updated twice, harmlessly)."""
        own = getattr(node, "_time_source", None)
        subscription = getattr(own, "_clock_sub", None)
        if subscription is None:  # wall time, or not an rclpy 7.1.6 node
            return
        if self._clock is None:
            clock_node = Node(
                CLOCK_NODE, context=self._context, use_global_arguments=False, start_parameter_services=False
            )
            source = SharedTimeSource(node=clock_node)
            source.ros_time_is_active = True
            executor = SingleThreadedExecutor(context=self._context)
            executor.add_node(clock_node)
            thread = threading.Thread(target=self._spin, args=(executor,), name="spin /clock", daemon=True)
            self._clock = (clock_node, source, executor, thread)
            thread.start()
        node.destroy_subscription(subscription)
        own._clock_sub = None
        self._clock[1].attach_clock(node.get_clock())

    def nodes(self) -> list[Node]:
        return [node for node, _, _ in self._spinners]

    def _spin(self, executor: Executor) -> None:
        try:
            executor.spin()
        except ExternalShutdownException:
            pass
        except Exception as error:  # a callback raised: its node no longer runs
            self._on_error(error)

    def shutdown(self, timeout_sec: float = 5.0) -> None:
        """Stop every executor (no callback runs afterwards) and join their threads; safe to call twice."""
        spinners = [(executor, thread) for _, executor, thread in self._spinners]
        if self._clock is not None:
            spinners.append(self._clock[2:])
        for executor, _ in spinners:
            executor.shutdown(timeout_sec=timeout_sec)
        for _, thread in spinners:
            thread.join(timeout=timeout_sec)
        if self._clock is not None:
            self._clock[0].destroy_node()
            self._clock = None
