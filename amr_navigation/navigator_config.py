"""The navigator node's parameters, each stated once (type, default, range, live or structural, description),
no ROS (amr_util.parameter_spec). Live ones (the goal, replanning, the request timeout) are used from the next
observation; the others shape what configure builds (topics, services, names) and are refused while configured.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from amr_navigation.navigator import DEFAULT_REPLAN_DISTANCE
from amr_navigation.navigator_core import DEFAULT_DRIVE_CONFIDENCE, DEFAULT_RELEASE_CONFIDENCE
from amr_navigation.traffic import TrafficConfig
from amr_planning.costmap import CostmapConfig
from amr_util.geometry import all_finite
from amr_util.parameter_spec import Config, ConfigError, parameter

NODE_NAME = "navigator"
COORDINATIONS = ("rules", "plan")
NOBODY_DRIVES = ("wait", "zero")


def _goal_problem(goal: list) -> str | None:
    return None if len(goal) in (0, 2) and all_finite(goal) else "must be [] or [x, y] (finite numbers)"


@dataclass(frozen=True)
class NavigatorConfig(Config):
    goal: list = parameter([], kind="float_array", check=_goal_problem, live=True)
    """[x, y] a first goal in global_frame; [] = none until a goal message (the latest goal wins: /goal_pose,
    world_goal_topic, or a set of this parameter)."""
    replan_distance: float = parameter(DEFAULT_REPLAN_DISTANCE, minimum=0.01, maximum=10.0, live=True)
    """m the estimate may be from the planned path before a new plan is made."""
    drive_confidence: float = parameter(DEFAULT_DRIVE_CONFIDENCE, minimum=0.0, maximum=1.0, live=True)
    """the localizer's confidence (/pose's posterior probability of its best place) at which the robot drives a
    path (below it: it explores); a localized /pose without a probability (confidence 0) counts as 1."""
    release_confidence: float = parameter(DEFAULT_RELEASE_CONFIDENCE, minimum=0.0, maximum=1.0, live=True)
    """... and under which it stops driving one and explores again (hysteresis, at most drive_confidence; 0.5: the
    best place no longer holds most of the belief). Below the particle filter's own release_probability (0.8), a
    short dip of its localized does not hand the robot to the wall follower and back."""
    plan_timeout: float = parameter(10.0, minimum=0.1, maximum=600.0, live=True)
    """s (wall clock) a ~/plan or ~/follow_path request may take before it counts as failed."""
    world_goal_topic: str = parameter("")
    """a latched geometry_msgs/PoseStamped topic whose messages are goals too (the simulator's /simulator/goal:
    the world's goal); '' = none."""
    planner_service: str = parameter("planner/plan", nonempty=True)
    """the planner's amr_interfaces/PlanPath service."""
    follow_path_service: str = parameter("path_follower/follow_path", nonempty=True)
    """the path follower's amr_interfaces/FollowPath service."""
    wall_follower: str = parameter("wall_follower", nonempty=True)
    """node name of the controller that explores (named in ~/status)."""
    path_follower: str = parameter("path_follower", nonempty=True)
    """node name of the controller that follows paths (named in ~/status; its <name>/status reports arrival
    and requests for a new plan)."""
    global_frame: str = parameter("map", nonempty=True)
    """frame of /pose, goals and paths (REP 105: map)."""
    nobody_drives: str = parameter("wait", choices=NOBODY_DRIVES)
    """what answers an observation this node gives nobody (IDLE, NO_PATH, REACHED), as the stack declares it. wait:
    no command; a lockstep world waits on that observation (its clock stands) until a new goal or route decides it
    again (maze_mapping: the explorer's next frontier), in real time the controller that had the robot stops it.
    zero: this node answers it with a zero TwistStamped on cmd_vel, stamped with the observation: the robot stands
    while a lockstep world goes on (/clock, ~/status), and a new goal is decided at the next observation."""
    # -- traffic rules among robots ----------------------------------------------------------------
    traffic: bool = parameter(False)
    """run the traffic rules among robots (amr_navigation.traffic): post on /traffic, read everyone's posts,
    cap the path follower's speed (speed_limit), plan around what is not on the map, give way. False: a robot
    alone, exactly as before (none of the traffic topics exist)."""
    priority: int = parameter(0, minimum=0, maximum=100000)
    """with traffic: lower goes first (the robot's index in the world's robots list)."""
    follower_speed: float = parameter(0.2, minimum=0.001, maximum=5.0, live=True)
    """m/s, with traffic: the path follower's linear_speed (the slow-down before an obstacle ramps up to it)."""
    post_timeout: float = parameter(3.0, minimum=0.1, maximum=600.0, live=True)
    """s (node clock), with traffic: another robot's post older than this is dropped (a robot gone quiet)."""
    traffic_rules: TrafficConfig = field(default_factory=TrafficConfig)
    """the rules' parameters (config/traffic.yaml's values are the defaults)."""
    costmap: CostmapConfig = field(default_factory=CostmapConfig)
    """with traffic: the costmap the rules read from /map (places aside, detours, what is unmapped): the planner's,
    amr_planning.costmap.shared_costmap (one object per process for equal maps and parameters): give it the planner
    node's robot_radius, safety_margin, cost_weight, cost_distance and margin_cost (the fleet_navigation stack ties
    them: its robot_radius and safety_margin arguments set both nodes)."""
    coordination: str = parameter("rules", choices=COORDINATIONS)
    """with traffic: how the robots share the world. rules: each robot by the traffic rules alone. plan: the rules
    until the fleet planner (amr_navigation fleet_planner) hands this robot a route on route_topic, then that route:
    the path follower driven through the waypoints it may drive to now, held where it may go no farther, by
    odometry from the last sure estimate while the localizer is unsure."""
    route_topic: str = parameter("fleet_route", nonempty=True)
    """with coordination plan: the fleet planner's amr_interfaces/FleetRoute for this robot (transient local)."""
    route_lifetime: float = parameter(30.0, minimum=0.0, maximum=3600.0)
    """s: a route expires this long after its stamp without a newer one (the fleet planner renews each halfway, a
    HOLD never): the navigator then goes back to its own planning (the traffic rules). The fleet planner's
    route_lifetime must be the same; 0 = routes never expire."""
    odometry_topic: str = parameter("odometry", nonempty=True)
    """with coordination plan: nav_msgs/Odometry of the localizer's observations (what the pose to drive by moves on
    with while the localizer is unsure)."""

    def validate(self) -> None:
        if self.release_confidence > self.drive_confidence:
            raise ConfigError(
                f"release_confidence: must be <= drive_confidence ({self.drive_confidence}), "
                f"got {self.release_confidence}"
            )
        if self.coordination == "plan" and not self.traffic:
            raise ConfigError(
                "coordination: 'plan' needs traffic: true (the robots go by the traffic rules until "
                "the fleet is planned)"
            )
