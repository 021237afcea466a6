"""amr_planning: costmaps, grid A*, the probabilistic roadmap and path smoothing (no ROS), and the planner node."""
