"""The fleet planner node's parameters, each stated once (amr_util.parameter_spec), no ROS. All shape what configure
builds (the robots, topics, the lattice) and are refused while configured."""

from __future__ import annotations

from dataclasses import dataclass, field

from amr_planning.costmap import CostmapConfig
from amr_util.parameter_spec import Config, ConfigError, parameter

NODE_NAME = "fleet_planner"


@dataclass(frozen=True)
class FleetPlannerConfig(Config):
    world: str = parameter("")
    """the world whose `robots` list names the fleet (a path, or a name under config/worlds, as the simulator's
    world); '' = the robots parameter names it."""
    robots: list = parameter([], kind="str_array")
    """the robots' names (their namespaces), in priority order; [] = the world's robots list (the fleet file: their
    `priority` keys, amr_navigation.fleet_file)."""
    lattice_spacing: float = parameter(0.4, minimum=0.1, maximum=5.0)
    """m between the points of the lattice the fleet is planned on (amr_planning.fleet_lattice.lattice: a square grid
    where it follows the free space, else points sampled along it at least this far apart): about a robot's width
    and its clearance; in a maze, the pitch of its cells."""
    status_topic: str = parameter("navigator/status", nonempty=True)
    """each robot's amr_interfaces/NavigatorStatus, in its namespace (/<robot>/navigator/status): where it stands,
    whether its navigator is confident (sure enough to drive a path), its goal."""
    route_topic: str = parameter("fleet_route", nonempty=True)
    """each robot's amr_interfaces/FleetRoute, in its namespace (/<robot>/fleet_route), transient local."""
    map_topic: str = parameter("/map", nonempty=True)
    """the one map (nav_msgs/OccupancyGrid, transient local) the lattice is made of."""
    global_frame: str = parameter("map", nonempty=True)
    """frame of the statuses' poses and goals and of the routes' waypoints."""
    window: float = parameter(0.5, minimum=0.0, maximum=60.0)
    """s: the robots' latest statuses must all say confident within this much of one another for the fleet to be
    planned (in lockstep they share each observation's stamp)."""
    retry_period: float = parameter(10.0, minimum=0.1, maximum=3600.0)
    """s (statuses' clock) after a plan that could not be made before the next try."""
    stuck_time: float = parameter(15.0, minimum=1.0, maximum=3600.0)
    """s (statuses' clock) a robot allowed to drive on may go without reaching its next waypoint before the lattice
    edge it is on counts as blocked (something not on the map): the edge is cut and the fleet planned again."""
    follower_speed: float = parameter(0.2, minimum=0.01, maximum=5.0)
    """m/s the plans are timed at (the path followers' linear_speed): of the searches' plans the one whose robots,
    driven by its action dependencies, would all arrive first is kept (amr_planning.fleet_execution.execution_time)."""
    turn_rate: float = parameter(1.0, minimum=0.01, maximum=10.0)
    """rad/s the plans are timed at for a robot turning in place where its way bends."""
    route_lifetime: float = parameter(30.0, minimum=0.0, maximum=3600.0)
    """s (statuses' clock) a route holds without a newer word: each FOLLOW is renewed halfway to it, a HOLD never;
    the navigators' own route_lifetime must be the same (0 = routes never expire)."""
    partial_replans: bool = parameter(True)
    """a stuck or jumped robot is planned again around the others, who drive on (false: the whole fleet is held
    and planned again)."""
    costmap: CostmapConfig = field(default_factory=CostmapConfig)
    """the costmap the lattice is made of, as the planners build theirs: give it the planner nodes' robot_radius and
    safety_margin (the fleet_navigation stack ties them)."""

    def coordinator(self, names: list[str], priorities: list[int] | None = None):
        """The FleetCoordinator these parameters make (the node's and the library fleet's: one place), for the robots
        `names` in priority order (`priorities`: the fleet file's)."""
        from amr_navigation.fleet_coordinator import FleetCoordinator

        return FleetCoordinator(
            names,
            self.lattice_spacing,
            window=self.window,
            retry_period=self.retry_period,
            stuck_time=self.stuck_time,
            follower_speed=self.follower_speed,
            turn_rate=self.turn_rate,
            priorities=priorities,
            route_lifetime=self.route_lifetime if self.route_lifetime > 0 else float("inf"),
            partial=self.partial_replans,
        )

    def validate(self) -> None:
        if not self.world and not self.robots:
            raise ConfigError("world, robots: one of them must name the fleet's robots")
        bad = [name for name in self.robots if not name or not name.replace("_", "a").isalnum()]
        if bad:
            raise ConfigError(f"robots: {bad[0]!r} is not a robot name (letters, digits and _)")
