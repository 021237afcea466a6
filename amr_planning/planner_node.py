"""planner: paths on a map on request (lifecycle node, a thin shell over Planner), as nav2's planner_server.

Map: the latest /map (nav_msgs/OccupancyGrid, transient local: map_server's, in every stack), or for
standalone use the world file of the `world` parameter rasterized at `resolution`.
~/plan (amr_interfaces/PlanPath) plans between any two poses of the map frame: a smoothed path, or
success false with the reason (unreachable goal, start in an obstacle, goal off the map, NaN) and
goal_refused when the goal itself can never be planned to. It answers only while the node is active.
A request may carry obstacle points and a mark_radius (the navigator's traffic rules planning around what is
not on the map): they are marked on a copy of the costmap for that plan only (Costmap.with_obstacles, through
Planner.with_obstacles); points that are not finite, more than MAX_OBSTACLES of them, or a mark_radius not in
[0, MAX_MARK_RADIUS] are refused with the reason.
The planner decides nothing: when to plan, and to which goal, is the navigator's decision
(amr_navigation): its paths to the goal, around the traffic rules' marks, and the legs through a fleet route's
waypoints all come here, as nav2's bt_navigator asks its planner_server. A failed request is logged once per
distinct reason, not at every retry.
The costmap is amr_planning.costmap.shared_costmap's: in a composed process the nodes given the same map and costmap
parameters (every robot's planner, the navigators' traffic rules, the fleet planner) hold one.
"""

from __future__ import annotations

import math

import numpy as np
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from rclpy.lifecycle import State, TransitionCallbackReturn

from amr_interfaces.srv import PlanPath
from amr_maps.messages import grid_from_message
from amr_maps.occupancy_grid import MapError
from amr_maps.rasterize import rasterize_world
from amr_maps.world import load_world, resolve_world_path
from amr_planning.costmap import shared_costmap
from amr_planning.errors import PlanningError
from amr_planning.messages import path_message
from amr_planning.planner import NODE_NAME, Planner, PlannerConfig
from amr_util.managed_node import ManagedNode, run
from amr_util.qos import LATCHED

MAX_OBSTACLES = 20000
"""obstacle points a ~/plan request may carry (a 240-beam scan extended behind each return is 480)."""
MAX_MARK_RADIUS = 1.0
"""m, the largest disc marked around an obstacle point."""


def request_obstacles(request) -> tuple[np.ndarray, float]:
    """(points (N, 2), mark radius) of a PlanPath request; ValueError with the reason for a malformed one."""
    count = len(request.obstacles)
    if count > MAX_OBSTACLES:
        raise ValueError(f"{count} obstacle points (at most {MAX_OBSTACLES})")
    radius = float(request.mark_radius)
    if not math.isfinite(radius) or not 0.0 <= radius <= MAX_MARK_RADIUS:
        raise ValueError(f"mark_radius {radius!r} is not a finite number of m in [0, {MAX_MARK_RADIUS}]")
    points = np.array([(p.x, p.y) for p in request.obstacles], dtype=float).reshape(-1, 2)
    if not np.isfinite(points).all():
        raise ValueError("an obstacle point is not finite")
    return points, radius


class PlannerNode(ManagedNode):
    """Wires Planner to /map and ~/plan; holds no planning logic and makes no decision."""

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(PlannerConfig.parameter_specs())
        self.config: PlannerConfig | None = None
        self.planner: Planner | None = None
        self._entities: list = []
        self._last_failure = ""
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
        self._entities = [self.create_active_service(PlanPath, "~/plan", self._on_plan_request)]
        if not config.world:
            self._entities.append(self.create_subscription(OccupancyGridMessage, "map", self._on_map, LATCHED))
        self.get_logger().info(f"configured: {config.planner}, map from {config.world or '/map'}")
        return TransitionCallbackReturn.SUCCESS

    def apply_live(self, changes: dict) -> None:
        """A tunable set while configured: checked as a whole, the costmap rebuilt from the current map."""
        config = PlannerConfig.from_params({**self.config.as_params(), **changes})  # ConfigError: refused
        self.config = config
        if self.planner is not None:
            self.planner = self._planner_of(self.planner.costmap.grid, config)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._entities = []
        self.config = self.planner = None
        self._last_failure = ""
        return super().on_cleanup(state)  # destroys what configure made

    def _load_world(self, config: PlannerConfig) -> None:
        world = load_world(resolve_world_path(config.world))
        self.planner = self._planner_of(rasterize_world(world, config.resolution), config)

    @staticmethod
    def _planner_of(grid, config: PlannerConfig) -> Planner:
        """The configured search on the process's costmap of this map (shared_costmap: built once per process)."""
        return Planner(grid, config, costmap=shared_costmap(grid, config.costmap))

    # -- the map and the service ------------------------------------------------------------------

    def _on_map(self, message: OccupancyGridMessage) -> None:
        if self.config is None:
            return
        try:
            self.planner = self._planner_of(grid_from_message(message), self.config)
        except (MapError, ValueError) as error:
            self.get_logger().error(f"/map refused, keeping the previous map: {error}")
            return
        self.get_logger().info(f"map {message.info.width} x {message.info.height} at {message.info.resolution} m")

    def _on_plan_request(self, request: PlanPath.Request, response: PlanPath.Response) -> PlanPath.Response:
        response.success = False
        if self.planner is None:
            response.message = "no map yet"
            return self._failed(response)
        start = (request.start.pose.position.x, request.start.pose.position.y)
        goal = (request.goal.pose.position.x, request.goal.pose.position.y)
        try:
            obstacles, radius = request_obstacles(request)
        except ValueError as error:
            response.message = f"obstacles refused: {error}"
            return self._failed(response)
        try:
            planner = self.planner.with_obstacles(obstacles, radius) if len(obstacles) else self.planner
            points = planner.plan(start, goal)
        except PlanningError as error:
            response.message, response.goal_refused = str(error), error.goal_refused
            return self._failed(response)
        except Exception as error:  # a planner bug must not take the node down
            response.message = f"planner failed: {error!r}"
            return self._failed(response)
        response.path = path_message(points, self.planner.costmap.grid.frame_id, self.get_clock().now().to_msg())
        response.success, response.message = True, f"{len(points)} points"
        self._last_failure = ""
        return response

    def _failed(self, response: PlanPath.Response) -> PlanPath.Response:
        """Log a refusal once: the same reason again (a navigator retrying) is not logged again."""
        if response.message != self._last_failure:
            self._last_failure = response.message
            self.get_logger().warning(f"~/plan refused: {response.message}")
        return response


def main(args=None) -> None:
    run(PlannerNode, args=args)


if __name__ == "__main__":
    main()
