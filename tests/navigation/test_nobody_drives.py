"""Nobody drives is an explicit hold with time going on: maze_navigation composed in lockstep, its
navigator declared `nobody_drives: zero`. After arrival and after a refused goal the navigator answers every
observation it gives nobody with a zero command, so the robot stands while /clock and /navigator/status go on, and a
goal sent then is driven to. (Before, the lockstep world stood still on the first such observation.)"""

from __future__ import annotations

import math

import yaml
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from support.ros import spin_until

from amr_bringup.composed import composed_stack
from amr_interfaces.msg import NavigatorStatus, SimulatorStatus
from amr_maps.world import resolve_world_path
from amr_util.lean_executor import LeanExecutor

RELIABLE = QoSProfile(depth=500, reliability=ReliabilityPolicy.RELIABLE)
FIRST_GOAL = [-0.8, -1.0, 0.15]
"""the world's goal: pillar_goal's moved to 0.7 m ahead of the start (a short first trip)."""
SECOND_GOAL = (-0.8, -0.5)
"""0.5 m on from it."""


class Watch(Node):
    """/clock, the navigator's statuses, the simulator's status and ground truth; publishes goals."""

    def __init__(self, context) -> None:
        super().__init__("nobody_drives_watch", context=context)
        self.clock: list[float] = []
        self.decisions: list[NavigatorStatus] = []
        self.status: list[SimulatorStatus] = []
        self.truth: Odometry | None = None
        self.create_subscription(Clock, "/clock", lambda m: self.clock.append(_seconds(m.clock)), RELIABLE)
        self.create_subscription(NavigatorStatus, "/navigator/status", self.decisions.append, RELIABLE)
        self.create_subscription(SimulatorStatus, "/simulator/status", self.status.append, RELIABLE)
        self.create_subscription(Odometry, "/ground_truth", self._on_truth, RELIABLE)
        self.goals = self.create_publisher(PoseStamped, "/goal_pose", RELIABLE)

    def _on_truth(self, message: Odometry) -> None:
        self.truth = message

    def now(self) -> float:
        return self.clock[-1] if self.clock else 0.0

    def last(self, mode: str | None = None, since: float = -1.0) -> NavigatorStatus | None:
        """The latest status (of `mode`) stamped after `since`."""
        for status in reversed(self.decisions):
            if _seconds(status.header.stamp) <= since:
                return None
            if mode is None or status.mode == mode:
                return status
        return None

    def travelled(self) -> float:
        return self.status[-1].distance_travelled if self.status else 0.0

    def send_goal(self, x: float, y: float) -> None:
        goal = PoseStamped()
        goal.header.frame_id = "map"
        goal.pose.position.x, goal.pose.position.y = x, y
        self.goals.publish(goal)


def _seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def test_after_arrival_and_a_refused_goal_time_goes_on_and_a_new_goal_is_reached(ros_context, tmp_path):
    world = yaml.safe_load(resolve_world_path("pillar_goal.yaml").read_text(encoding="utf-8"))
    world["goal"] = FIRST_GOAL
    (tmp_path / "world.yaml").write_text(yaml.safe_dump(world), encoding="utf-8")
    arguments = {"world": str(tmp_path / "world.yaml")}
    with composed_stack(ros_context, "maze_navigation", arguments=arguments) as (nodes, manager, _):
        watch = Watch(ros_context)
        executor = LeanExecutor(context=ros_context)
        executor.add_node(watch)
        try:
            steps = manager.startup()
            assert all(step.ok for step in steps), [(step.node, step.detail) for step in steps if not step.ok]
            assert nodes["navigator"].get_parameter("nobody_drives").value == "zero"

            assert spin_until(executor, lambda: watch.last("REACHED") is not None, 120.0), (
                f"the world's goal not reached by {watch.now():.2f} s: {[d.mode for d in watch.decisions[-3:]]}"
            )
            arrived = _seconds(watch.last("REACHED").header.stamp)
            _time_goes_on_while_it_stands(executor, watch, "REACHED", arrived)

            watch.send_goal(0.0, 0.0)  # inside the pillar: refused, nobody drives
            assert spin_until(executor, lambda: watch.last("NO_PATH", since=arrived) is not None, 30.0)
            refused = watch.last("NO_PATH")
            assert "refused" in refused.reason or "obstacle" in refused.reason, refused.reason
            _time_goes_on_while_it_stands(executor, watch, "NO_PATH", _seconds(refused.header.stamp))

            sent = watch.now()
            watch.send_goal(*SECOND_GOAL)
            assert spin_until(
                executor,
                lambda: (s := watch.last("REACHED", since=sent)) is not None and s.goal.x == SECOND_GOAL[0],
                120.0,
            ), f"the new goal not reached by {watch.now():.2f} s: {[d.mode for d in watch.decisions[-3:]]}"
            position = watch.truth.pose.pose.position
            assert math.hypot(position.x - SECOND_GOAL[0], position.y - SECOND_GOAL[1]) < 0.15
            assert watch.status[-1].collisions == 0
            assert nodes["navigator"].holds_sent >= 40  # 1 s after arrival and 1 s refused, a zero per step
        finally:
            executor.remove_node(watch)
            executor.shutdown()
            watch.destroy_node()


def _time_goes_on_while_it_stands(executor, watch: Watch, mode: str, since: float) -> None:
    """/clock and the navigator's statuses (of `mode`) go on a simulated second past `since`; the robot stands."""
    travelled = watch.travelled()
    assert spin_until(executor, lambda: watch.now() > since + 1.0, 30.0), (
        f"/clock stood at {watch.now():.2f} s after {mode} at {since:.2f} s"
    )
    assert spin_until(executor, lambda: watch.last(mode, since=since + 1.0) is not None, 10.0), (
        f"no {mode} status after {since + 1.0:.2f} s: "
        + str([(d.mode, _seconds(d.header.stamp)) for d in watch.decisions[-3:]])
    )
    assert watch.travelled() - travelled < 0.005, "the robot stood while nobody drove"
