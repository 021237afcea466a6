"""amr_evaluation: closed-loop harnesses that drive the simulator and the algorithms together, without ROS.

On top of the package graph (beside amr_bringup): it may import every runtime package, and no runtime
package imports it. closed_loop runs the wall follower and the particle filter on a simulator in
lockstep (the tests and bench/bench_localization.py use it).
"""
