"""explorer: frontier exploration as a lifecycle node (`ros2 run amr_mapping explorer`), a thin shell over
amr_mapping.explorer.Explorer.

Inputs: /map (nav_msgs/OccupancyGrid, transient local: the slam node's), /pose (amr_interfaces/LocalizedPose:
the slam node's), and the navigator's ~/status (amr_interfaces/NavigatorStatus).
Decisions: at a /pose after a new map (at most every decision_period s of pose time while a goal is being driven
to; at once without one), and at once when the navigator reports the explorer's goal REACHED (the frontier it
was chosen for is given up: the next frontier is chosen) or NO_PATH (the goal is blacklisted). A goal without
progress for goal_timeout s of pose time (its frontier's path no shorter) is blacklisted too.
Outputs: a new goal as geometry_msgs/PoseStamped on /goal_pose (the navigator's goal input, frame map); ~/frontiers
(amr_interfaces/Frontiers, transient local: a viewer started late gets the last ones) and ~/status (std_msgs/String:
the state and why) after every decision. With nothing reachable left the state is `done`; with `save_to` set, the
slam node's ~/save_map is then called with it (once per time exploration ends), and the answer is logged.

In lockstep the navigator holds the robot while it has no goal (IDLE) or has reached it (REACHED): the goal
sent on that status makes it decide the held observation again, so the loop goes on without a new scan.
"""

from __future__ import annotations

import math

from geometry_msgs.msg import Point, PoseStamped
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from rclpy.lifecycle import State, TransitionCallbackReturn
from std_msgs.msg import String

from amr_interfaces.msg import Frontiers, LocalizedPose, NavigatorStatus
from amr_interfaces.srv import SaveMap
from amr_mapping.explorer import DONE, Explorer, ExplorerConfig, Step
from amr_maps.messages import grid_from_message
from amr_maps.occupancy_grid import OccupancyGrid
from amr_util.geometry import all_finite, yaw_from_quaternion
from amr_util.managed_node import ManagedNode, run
from amr_util.parameter_spec import ParameterSpec
from amr_util.qos import LATCHED, reliable
from amr_util.stamps import stamp_seconds

NODE_NAME = "explorer"
GOAL_MATCH = 0.05
"""m: the navigator's status is about the explorer's goal when its goal lies this close."""

NODE_SPECS = (
    ParameterSpec("global_frame", "map", "frame of /map, /pose and the goals"),
    ParameterSpec("map_topic", "map", "nav_msgs/OccupancyGrid (transient local): the map being built"),
    ParameterSpec("pose_topic", "pose", "amr_interfaces/LocalizedPose: the robot in the map"),
    ParameterSpec("goal_topic", "goal_pose", "geometry_msgs/PoseStamped: where the navigator takes goals"),
    ParameterSpec(
        "navigator_status",
        "navigator/status",
        "amr_interfaces/NavigatorStatus: REACHED and NO_PATH of the explorer's goal",
    ),
    ParameterSpec(
        "decision_period",
        1.0,
        "s of pose time at least between two decisions on new maps while a goal is "
        "driven to (explore_lite planner_frequency's inverse)",
        minimum=0.0,
        maximum=3600.0,
        live=True,
    ),
    ParameterSpec(
        "save_to",
        "",
        "when exploration is done, the slam node's ~/save_map is called with this path "
        "(<path>.yaml, .pgm, .poses.csv); '' = the map is not saved",
        live=True,
    ),
    ParameterSpec("save_map_service", "slam/save_map", "amr_interfaces/SaveMap service called with save_to"),
)
NODE_NAMES = frozenset(spec.name for spec in NODE_SPECS)


def parameter_specs() -> tuple[ParameterSpec, ...]:
    return ExplorerConfig.parameter_specs() + NODE_SPECS


def config_of(values: dict) -> ExplorerConfig:
    return ExplorerConfig.from_params({name: value for name, value in values.items() if name not in NODE_NAMES})


class ExplorerNode(ManagedNode):
    """Wires Explorer to /map, /pose, the navigator's goal and status, and the slam node's ~/save_map."""

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(parameter_specs())
        self.explorer: Explorer | None = None
        self._settings: dict = {}
        self._outputs: dict = {}
        self._entities: list = []
        self._save_client = None
        self._grid: OccupancyGrid | None = None
        self._map_new = False
        self._pose: tuple[float, float, float] | None = None
        self._stamp = None
        self._now = 0.0
        self._last_decision = -math.inf
        self._last_state = ""
        self.last_step: Step | None = None
        self.save_answer: SaveMap.Response | None = None
        self.configure_error = ""

    # -- lifecycle ------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        values = self.parameter_values()
        if not problems:
            try:
                config = config_of(values)
            except ValueError as error:
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            return self.fail_configure(problems)
        self.explorer = Explorer(config)
        self._settings = {name: values[name] for name in NODE_NAMES}
        self._outputs = {
            "goal": self.create_lifecycle_publisher(PoseStamped, values["goal_topic"], reliable()),
            "frontiers": self.create_lifecycle_publisher(Frontiers, "~/frontiers", LATCHED),
            "status": self.create_lifecycle_publisher(String, "~/status", reliable()),
        }
        self._entities = [
            self.create_subscription(OccupancyGridMessage, values["map_topic"], self._on_map, LATCHED),
            self.create_subscription(LocalizedPose, values["pose_topic"], self._on_pose, reliable()),
            self.create_subscription(NavigatorStatus, values["navigator_status"], self._on_navigator, reliable()),
        ]
        self._save_client = self.create_client(SaveMap, values["save_map_service"])
        self.get_logger().info(
            f"configured: frontiers of {values['map_topic']}, goals on {values['goal_topic']}"
            + (f"; saves to {values['save_to']} when done" if values["save_to"] else "")
        )
        return TransitionCallbackReturn.SUCCESS

    def apply_live(self, changes: dict) -> None:
        library = {name: value for name, value in changes.items() if name not in NODE_NAMES}
        if library:
            self.explorer.config = ExplorerConfig.from_params({**self.explorer.config.as_params(), **library})
        self._settings.update({name: value for name, value in changes.items() if name in NODE_NAMES})

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._last_decision, self._last_state = -math.inf, ""
        return super().on_activate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._entities, self._outputs, self._save_client = [], {}, None
        self.explorer, self._grid, self._pose = None, None, None
        return super().on_cleanup(state)  # destroys what configure made

    @property
    def active(self) -> bool:
        return self.state_label == "active" and self.explorer is not None

    # -- inputs ---------------------------------------------------------------------------------

    def _on_map(self, message: OccupancyGridMessage) -> None:
        try:
            self._grid, self._map_new = grid_from_message(message), True
        except Exception as error:  # a malformed map: keep the previous one
            self.get_logger().error(f"map refused: {error}", throttle_duration_sec=2.0)
            return
        if self.active and (self.explorer.goal is None and self._pose is not None):
            self._decide()

    def _on_pose(self, message: LocalizedPose) -> None:
        if not self.active:
            return
        p = message.pose.pose
        pose = (p.position.x, p.position.y, yaw_from_quaternion(p.orientation))
        if not all_finite(pose):
            self.get_logger().warning("a non-finite /pose was ignored", throttle_duration_sec=2.0)
            return
        self._pose, self._stamp, self._now = pose, message.header.stamp, stamp_seconds(message.header.stamp)
        if self.explorer.goal is None and self._last_state != DONE:
            self._decide()
        elif self._map_new and self._now - self._last_decision >= self._settings["decision_period"]:
            self._decide()
        elif (
            self.explorer.goal is not None and self._now - self.explorer.goal_since > self.explorer.config.goal_timeout
        ):
            self._decide()

    def _on_navigator(self, message: NavigatorStatus) -> None:
        if not self.active or self.explorer.goal is None or not message.has_goal:
            return
        gx, gy = self.explorer.goal
        if math.hypot(message.goal.x - gx, message.goal.y - gy) > GOAL_MATCH:
            return  # about an earlier goal (or another's)
        if message.mode == "REACHED":
            self.get_logger().info(f"goal ({gx:.2f}, {gy:.2f}) reached")
            self.explorer.reached()
        elif message.mode == "NO_PATH":
            self.explorer.failed(f"the navigator: {message.reason}")
        else:
            return
        self._decide()

    # -- decisions ------------------------------------------------------------------------------

    def _decide(self) -> None:
        try:
            step = self.explorer.update(self._grid, self._pose, self._now)
        except Exception as error:  # an explorer bug must not take the node down
            self.get_logger().error(
                f"exploration step failed: {type(error).__name__}: {error}", throttle_duration_sec=2.0
            )
            return
        self._map_new, self._last_decision, self.last_step = False, self._now, step
        for event in self.explorer.take_events():
            self.get_logger().info(event)
        if step.new_goal and step.goal is not None and all_finite(step.goal):
            self._send_goal(step.goal)
        self._publish(step)
        if step.state == DONE and self._last_state != DONE:
            self.get_logger().info(f"exploration done: {step.reason}")
            self._save()
        self._last_state = step.state

    def _send_goal(self, goal: tuple[float, float]) -> None:
        message = PoseStamped()
        message.header.frame_id = self._settings["global_frame"]
        if self._stamp is not None:
            message.header.stamp = self._stamp
        message.pose.position.x, message.pose.position.y = float(goal[0]), float(goal[1])
        message.pose.orientation.w = 1.0
        self._outputs["goal"].publish(message)

    def _publish(self, step: Step) -> None:
        message = Frontiers(state=step.state, chosen=int(step.chosen), blacklisted=self.explorer.given_up_count)
        message.header.frame_id = self._settings["global_frame"]
        if self._stamp is not None:
            message.header.stamp = self._stamp
        message.centroids = [Point(x=float(f.centroid[0]), y=float(f.centroid[1])) for f in step.frontiers]
        message.sizes = [int(f.size) for f in step.frontiers]
        self._outputs["frontiers"].publish(message)
        self._outputs["status"].publish(String(data=f"{step.state}: {step.reason}"))

    def _save(self) -> None:
        path = self._settings["save_to"]
        if not path:
            return
        if not self._save_client.service_is_ready():
            self.get_logger().error(
                f"exploration done, but {self._save_client.srv_name} is not available: the map was not saved to {path}"
            )
            return
        self._save_client.call_async(SaveMap.Request(path=path)).add_done_callback(self._saved)

    def _saved(self, future) -> None:
        try:
            self.save_answer = answer = future.result()
        except Exception as error:
            self.get_logger().error(f"save_map failed: {error}")
            return
        if answer.success:
            self.get_logger().info(f"map saved: {answer.message}")
        else:
            self.get_logger().error(f"map not saved: {answer.message}")


def main(args=None) -> None:
    run(ExplorerNode, args=args)


if __name__ == "__main__":
    main()
