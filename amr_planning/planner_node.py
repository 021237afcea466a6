"""planner: a path on the map from the localized pose to the goal (lifecycle node, a thin shell over Planner).

Map: the world file of the `world` parameter rasterized at `resolution`, or else the latest
/map (nav_msgs/OccupancyGrid, transient local). Goal: the `goal` parameter, else the world's goal,
else the latest /goal_pose (geometry_msgs/PoseStamped, RViz's 2D Goal Pose; a new one replaces it).
It plans when /pose (amr_interfaces/LocalizedPose) first says localized, again when the goal
changes or the pose strays more than `replan_distance` from the path, and publishes /path
(nav_msgs/Path, frame map, transient local). A request it cannot serve (unreachable goal, start in
an obstacle, goal off the map, NaN) is logged with its reason and nothing is published.
~/plan (amr_interfaces/PlanPath) plans between any two poses on request.
"""

from __future__ import annotations

import math

import numpy as np
from amr_interfaces.msg import LocalizedPose
from amr_interfaces.srv import PlanPath
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from nav_msgs.msg import Path
from rclpy.lifecycle import State, TransitionCallbackReturn

from amr_maps.messages import grid_from_message
from amr_maps.occupancy_grid import MapError
from amr_maps.rasterize import rasterize_world
from amr_maps.world import load_world, resolve_world_path
from amr_planning.errors import PlanningError
from amr_planning.planner import NODE_NAME, Planner, PlannerConfig, distance_to_path
from amr_util.managed_node import ManagedNode, run
from amr_util.messages import quaternion
from amr_util.qos import LATCHED

WARNING_PERIOD = 2.0


class PlannerNode(ManagedNode):
    """Wires Planner to /map, /pose, /goal_pose, /path and ~/plan; holds no planning logic."""

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(PlannerConfig.parameter_specs())
        self.config: PlannerConfig | None = None
        self.planner: Planner | None = None
        self.path: np.ndarray | None = None
        self._goal: tuple[float, float] | None = None
        self._planned_goal: tuple[float, float] | None = None
        self._entities: list = []
        self._path_publisher = None
        self.configure_error = ""

    # -- lifecycle ------------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if not problems:
            try:
                config = PlannerConfig.from_params(self.parameter_values())
                if config.world:
                    self._load_world(config)
            except (ValueError, OSError) as error:  # ConfigError, MapError, PlanningError name the problem
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            return self.fail_configure(problems)
        self.config = config
        if config.goal:
            self._goal = (config.goal[0], config.goal[1])
        self._path_publisher = self.create_lifecycle_publisher(Path, "path", LATCHED)
        self._entities = [
            self.create_subscription(OccupancyGridMessage, "map", self._on_map, LATCHED),
            self.create_subscription(LocalizedPose, "pose", self._on_pose, 10),
            self.create_subscription(PoseStamped, "goal_pose", self._on_goal, 10),
            self.create_service(PlanPath, "~/plan", self._on_plan_request),
        ]
        self.get_logger().info(f"configured: {config.planner}, map from {config.world or '/map'}")
        return TransitionCallbackReturn.SUCCESS

    def apply_live(self, changes: dict) -> None:
        """A tunable set while configured: checked as a whole, the costmap rebuilt from the current map."""
        config = PlannerConfig.from_params({**self.config.as_params(), **changes})  # ConfigError: refused
        self.config = config
        if self.planner is not None:
            self.planner = Planner(self.planner.costmap.grid, config)
        if "goal" in changes and config.goal:
            self._goal = (config.goal[0], config.goal[1])
        self.path = None  # plan again at the next localized pose

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        for entity in self._entities:
            (self.destroy_service if hasattr(entity, "srv_type") else self.destroy_subscription)(entity)
        self.destroy_lifecycle_publisher(self._path_publisher)
        self._entities, self._path_publisher = [], None
        self.config = self.planner = self.path = None
        self._goal = self._planned_goal = None
        return TransitionCallbackReturn.SUCCESS

    def _load_world(self, config: PlannerConfig) -> None:
        world = load_world(resolve_world_path(config.world))
        self.planner = Planner(rasterize_world(world, config.resolution), config)
        if world.goal is not None and not config.goal:
            self._goal = (world.goal.x, world.goal.y)

    # -- inputs -----------------------------------------------------------------------------------

    def _on_map(self, message: OccupancyGridMessage) -> None:
        if self.config is None or self.config.world:
            return
        try:
            self.planner = Planner(grid_from_message(message), self.config)
        except (MapError, ValueError) as error:
            self.get_logger().error(f"/map refused, keeping the previous map: {error}")
            return
        self.path = None  # a new map: plan again at the next pose
        self.get_logger().info(f"map {message.info.width} x {message.info.height} at {message.info.resolution} m")

    def _on_goal(self, message: PoseStamped) -> None:
        goal = (message.pose.position.x, message.pose.position.y)
        if not all(math.isfinite(v) for v in goal):
            self.get_logger().error(f"/goal_pose refused: not finite {goal}")
            return
        if self.config is not None and self.config.goal:
            self.get_logger().warning("/goal_pose ignored: the goal parameter is set")
            return
        self._goal = goal

    def _on_pose(self, message: LocalizedPose) -> None:
        if self.state_label != "active" or not message.localized or self.planner is None or self._goal is None:
            return
        x, y = message.pose.pose.position.x, message.pose.pose.position.y
        if not (math.isfinite(x) and math.isfinite(y)):
            self.get_logger().warning("a non-finite /pose was ignored", throttle_duration_sec=WARNING_PERIOD)
            return
        if self.path is not None and self._planned_goal == self._goal:
            if distance_to_path(self.path, x, y) <= self.config.replan_distance:
                return
            self.get_logger().info(f"strayed more than {self.config.replan_distance} m from the path: planning again")
        self._planned_goal = self._goal
        try:
            self.path = self.planner.plan((x, y), self._goal)
        except PlanningError as error:
            self.path = None
            self.get_logger().error(f"no path: {error}", throttle_duration_sec=WARNING_PERIOD)
            return
        except Exception as error:  # a planner bug must not take the node down
            self.path = None
            self.get_logger().error(f"planner failed: {error!r}", throttle_duration_sec=WARNING_PERIOD)
            return
        self._path_publisher.publish(self._path_message(self.path))
        self.get_logger().info(f"path of {len(self.path)} points to ({self._goal[0]:.2f}, {self._goal[1]:.2f})")

    def _on_plan_request(self, request: PlanPath.Request, response: PlanPath.Response) -> PlanPath.Response:
        response.success = False
        if self.planner is None:
            response.message = "no map yet"
            return response
        start = (request.start.pose.position.x, request.start.pose.position.y)
        goal = (request.goal.pose.position.x, request.goal.pose.position.y)
        try:
            points = self.planner.plan(start, goal)
        except PlanningError as error:
            response.message = str(error)
            return response
        except Exception as error:
            response.message = f"planner failed: {error!r}"
            return response
        response.path = self._path_message(points)
        response.success, response.message = True, f"{len(points)} points"
        return response

    def _path_message(self, points: np.ndarray) -> Path:
        message = Path()
        message.header.stamp = self.get_clock().now().to_msg()
        message.header.frame_id = self.planner.costmap.grid.frame_id
        headings = np.arctan2(*np.diff(points, axis=0).T[::-1]) if len(points) > 1 else np.zeros(1)
        headings = np.append(headings, headings[-1])
        for (x, y), heading in zip(points, headings):
            pose = PoseStamped()
            pose.header = message.header
            pose.pose.position.x, pose.pose.position.y = float(x), float(y)
            pose.pose.orientation = quaternion(heading)
            message.poses.append(pose)
        return message


def main(args=None) -> None:
    run(PlannerNode, args=args)


if __name__ == "__main__":
    main()
