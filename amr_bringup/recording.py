"""amr-bringup --record: the recorder executable as a process of its own, as `ros2 bag record` runs.

In amr-bringup's process it shared the GIL with a composed stack: a composed lockstep maze_sim ran
54 % slower while recording every topic, against 17 % as a process (bench/bench_record.py). The
lifecycle manager activates each node only once the recorder's `~/caught_up` says it listens to
every topic there is and, for a composed stack, once the node's own publishers have matched the
recorder too (wait_until_matched), so a lockstep run's first observation is in the bag.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection, Sequence

from rclpy.node import Node
from std_srvs.srv import Trigger

from amr_bringup.processes import NodeProcess, executable_path
from amr_bringup.status import IGNORED_SUFFIXES, IGNORED_TOPICS

SERVICE_TIMEOUT = 15.0
"""s for the recorder process to come up and offer ~/caught_up."""
CATCH_UP_TIMEOUT = 3.0
"""s a startup waits for the recorder to subscribe to a node's topics before activating it."""
MATCH_SETTLE = 0.05
"""s after the match is seen: the writer side learns of the new reader a moment after the reader sees it."""


def recorder_command(name: str, path: str, topics: Sequence[str], simulated: bool) -> list[str]:
    command = [
        str(executable_path("amr_bringup", "recorder")),
        "--ros-args",
        "-r",
        f"__node:={name}",
        "-p",
        f"path:={path}",
        "-p",
        f"use_sim_time:={'true' if simulated else 'false'}",
    ]
    if topics:
        command += ["-p", f"topics:=[{', '.join(topics)}]"]
    return command


class RecorderProcess:
    """The recorder process (node `name`) and a client of its ~/caught_up on `client_node` (which the caller
    spins)."""

    def __init__(
        self,
        name: str,
        path: str,
        topics: Sequence[str],
        simulated: bool,
        client_node: Node,
        write: Callable[[str], None],
    ) -> None:
        self.command = recorder_command(name, path, topics, simulated)
        self.process = NodeProcess(name, self.command, write)
        self._client = client_node.create_client(Trigger, f"/{name}/caught_up")
        self._log = client_node.get_logger()

    def wait_until_caught_up(self, timeout: float = CATCH_UP_TIMEOUT) -> bool:
        """Block until the recorder says it is caught up (at most `timeout` s once its service is up)."""
        if not self._client.wait_for_service(timeout_sec=SERVICE_TIMEOUT):
            self._log.error(f"the recorder offered no ~/caught_up within {SERVICE_TIMEOUT} s: not waiting for it")
            return False
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and self.process.exit_code() is None:
            response = self._client.call(Trigger.Request(), timeout_sec=timeout)
            if response is not None and response.success:
                time.sleep(MATCH_SETTLE)
                return True
            time.sleep(0.02)
        self._log.warning(f"the recorder was not caught up within {timeout} s: its bag may miss the first messages")
        return False


def recorded_by_default(topic: str) -> bool:
    """What the recorder records when no topics are named (its `eligible`)."""
    return topic not in IGNORED_TOPICS and not topic.endswith(IGNORED_SUFFIXES)


def wait_until_matched(node: Node, topics: Collection[str], timeout: float = CATCH_UP_TIMEOUT) -> list[str]:
    """Block until each of `node`'s publishers on `topics` (if empty: every topic the recorder records) has matched
    every subscription the graph shows on its topic, at most `timeout` s; returns the topics still unmatched.

    The recorder's ~/caught_up sees only its own side of each match. A loaded machine can deliver the
    reader's announcement to the writer's process seconds later, and a volatile writer drops what it
    publishes before that: a lockstep run lost its first observations that way under load."""
    deadline = time.monotonic() + timeout
    while True:
        pending = sorted(
            {
                publisher.topic_name
                for publisher in node.publishers
                if (publisher.topic_name in topics if topics else recorded_by_default(publisher.topic_name))
                and publisher.get_subscription_count() < node.count_subscribers(publisher.topic_name)
            }
        )
        if not pending or time.monotonic() > deadline:
            return pending
        time.sleep(0.01)
