"""The navigator node's ROS parameters, one spec each (type, default, range, description, live or not), no ROS."""

from __future__ import annotations

import math

from amr_navigation.navigator import DEFAULT_REPLAN_DISTANCE
from amr_util.parameter_spec import ParameterSpec

NODE_NAME = "navigator"


def _goal_problem(value) -> str | None:
    if len(value) not in (0, 2) or not all(math.isfinite(v) for v in value):
        return "must be [] or [x, y] (finite numbers, in global_frame)"
    return None


def parameter_specs() -> tuple[ParameterSpec, ...]:
    return (
        ParameterSpec("goal", [], "[x, y] a first goal in global_frame; [] = none until a goal message (the latest "
                      "goal wins: /goal_pose, world_goal_topic, or a set of this parameter)", kind="float_array",
                      live=True, check=_goal_problem),
        ParameterSpec("replan_distance", DEFAULT_REPLAN_DISTANCE, "m the estimate may be from the planned path before "
                      "a new plan is made", minimum=0.01, maximum=10.0, live=True),
        ParameterSpec("plan_timeout", 10.0, "s (wall clock) a ~/plan or ~/follow_path request may take before it "
                      "counts as failed", minimum=0.1, maximum=600.0, live=True),
        ParameterSpec("world_goal_topic", "", "a latched geometry_msgs/PoseStamped topic whose messages are goals too "
                      "(the simulator's /simulator/goal: the world's goal); '' = none"),
        ParameterSpec("planner_service", "planner/plan", "the planner's amr_interfaces/PlanPath service"),
        ParameterSpec("follow_path_service", "path_follower/follow_path",
                      "the path follower's amr_interfaces/FollowPath service"),
        ParameterSpec("wall_follower", "wall_follower", "node name of the controller that explores (named in ~/status)"),
        ParameterSpec("path_follower", "path_follower", "node name of the controller that follows paths (named in "
                      "~/status; its <name>/status reports arrival and requests for a new plan)"),
        ParameterSpec("global_frame", "map", "frame of /pose, goals and paths (REP 105: map)"),
    )
