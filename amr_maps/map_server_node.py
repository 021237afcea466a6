"""map_server: a map on /map as nav2's map_server serves it (`ros2 run amr_maps map_server`).

configure  loads the map named by `yaml_filename` (a map_server YAML + image) or `world` (a world file,
           rasterized at `resolution`), stamps its load time with the node clock, and creates the
           publisher and the `~/map` service (nav_msgs/srv/GetMap); a malformed file fails the
           transition naming the file and the key, and leaves nothing behind.
activate   publishes the map once on `topic_name` with transient-local durability (amr_util.qos.LATCHED):
           a subscriber that joins later still gets it, as from nav2's map_server.
cleanup    frees the map, the publisher and the service.

In a simulated stack it serves the simulator's world (the same `world` argument), so the simulator
stays a simulator and the map is published the way a real robot's stack publishes it.
"""

from __future__ import annotations

from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from nav_msgs.srv import GetMap
from rclpy.lifecycle import State, TransitionCallbackReturn

from amr_maps.map_source import load_grid, parameter_specs
from amr_maps.messages import grid_message
from amr_maps.world import world_problem
from amr_util.managed_node import ManagedNode, run
from amr_util.qos import LATCHED


class MapServerNode(ManagedNode):
    """A thin shell: parameters in, amr_maps loads, one latched message out, GetMap answered."""

    def __init__(self, **kwargs) -> None:
        super().__init__("map_server", **kwargs)
        self.declare_specs(parameter_specs(world_problem))
        self._message: OccupancyGridMessage | None = None
        self._publisher = None
        self._service = None

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if problems:
            return self.fail_configure(problems)
        try:
            grid = load_grid(self.parameter_values())
        except ValueError as error:  # MapError names the parameter, the file and the key
            return self.fail_configure([str(error)])
        now = self.get_clock().now().to_msg()
        self._message = grid_message(grid, now, now)
        self._publisher = self.create_lifecycle_publisher(
            OccupancyGridMessage, self.get_parameter("topic_name").value, LATCHED
        )
        self._service = self.create_active_service(GetMap, "~/map", self._on_get_map)
        self.get_logger().info(
            f"map {grid.width} x {grid.height} cells at {grid.resolution} m, origin {grid.origin[:2]}, "
            f"frame {grid.frame_id}, on {self._publisher.topic_name}"
        )
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        result = super().on_activate(state)
        self._message.header.stamp = self.get_clock().now().to_msg()
        self._publisher.publish(self._message)
        return result

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._teardown()
        return super().on_cleanup(state)  # and whatever else configure made

    def _teardown(self) -> None:
        if self._service is not None:
            self.destroy_service(self._service)
        if self._publisher is not None:
            self.destroy_lifecycle_publisher(self._publisher)
        self._message, self._publisher, self._service = None, None, None

    def _on_get_map(self, request: GetMap.Request, response: GetMap.Response) -> GetMap.Response:
        """The map as last published (nav2 answers the same message)."""
        if self._message is not None:
            response.map = self._message
        return response


def main(args=None) -> None:
    run(MapServerNode, args=args)


if __name__ == "__main__":
    main()
