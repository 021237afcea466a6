"""amr_evaluation: evaluation at scale, without ROS by default.

Episodes as pure functions of their spec (episode), sweeps of them run locally or on a Dask cluster
(runner, amr-evaluate), the closed-loop harnesses they drive (closed_loop: the wall follower and the
particle filter in lockstep; wall_follower_loop; plan_follow), and a Gymnasium environment over the
simulator library (gym_env: amr/Maze-v0).

On top of the package graph (beside amr_bringup): it may import every runtime package, and no runtime
package imports it (only bench/ and tests/ do).
"""
