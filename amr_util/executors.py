"""Several nodes in one process, each spun by an executor and a thread of its own.

Measured on maze_sim composed (map_server, simulator, wall follower, lifecycle manager; lockstep):
one MultiThreadedExecutor(4) over all nodes ran 0.5x real time, one SingleThreadedExecutor 16x,
and one SingleThreadedExecutor per node 12x. rclpy's MultiThreadedExecutor rebuilds one big wait set
and hands every ready callback to its pool through futures; the lockstep loop waits on that hand-off
at every step. One executor per node keeps the nodes independent (a blocking service call in the
lifecycle manager, or a long solve in the IK service, stops no other node) at almost the speed of a
single executor. A node whose callbacks must overlap (a reentrant group) says so with the class
attribute `multithreaded_executor = True` and gets a MultiThreadedExecutor of its own; every other node
a LeanExecutor (amr_util.lean_executor: rclpy's SingleThreadedExecutor without its per-wake-up rebuild,
half the CPU per callback).
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from rclpy.executors import Executor, ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node

from amr_util.lean_executor import LeanExecutor


def executor_for(node: Node, context=None) -> Executor:
    """The executor a node spins on: a MultiThreadedExecutor where its class says `multithreaded_executor = True`
    (callbacks that must overlap), else a LeanExecutor."""
    if getattr(node, "multithreaded_executor", False):
        return MultiThreadedExecutor(context=context)
    return LeanExecutor(context=context)


class NodeSpinners:
    """add_node() starts spinning a node at once; shutdown() stops every spinner (the nodes stay, for the caller
    to destroy). An exception out of a callback stops that node's spinner and is passed to `on_error`."""

    def __init__(self, context=None, on_error: Callable[[BaseException], None] = lambda error: None) -> None:
        self._context = context
        self._on_error = on_error
        self._spinners: list[tuple[Node, Executor, threading.Thread]] = []

    def add_node(self, node: Node) -> None:
        executor = executor_for(node, self._context)
        executor.add_node(node)
        thread = threading.Thread(target=self._spin, args=(executor,), name=f"spin {node.get_name()}", daemon=True)
        self._spinners.append((node, executor, thread))
        thread.start()

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
        for _, executor, _ in self._spinners:
            executor.shutdown(timeout_sec=timeout_sec)
        for _, _, thread in self._spinners:
            thread.join(timeout=timeout_sec)
