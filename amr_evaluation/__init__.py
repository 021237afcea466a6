"""amr_evaluation: evaluation at scale, without ROS by default.

Episodes as pure functions of their spec (episode), sweeps of them run locally or on a Dask cluster
(runner, amr-evaluate), the closed loops they drive, each a set of parts on the lockstep harness
amr_util.harness (closed_loop: the wall follower and the particle filter; wall_follower_loop; plan_follow;
crowded_localization; fleet_navigation), and a Gymnasium environment over the simulator library (gym_env:
amr/Maze-v0, stepped by the same harness).

On top of the package graph (beside amr_bringup): it may import every runtime package, and no runtime
package imports it (only bench/ and tests/ do).
"""
