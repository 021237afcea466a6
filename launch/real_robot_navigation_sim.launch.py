"""ros2 launch amr_bringup real_robot_navigation_sim.launch.py: real_robot_navigation rehearsed on the simulator in
real time.

The nodes, their parameters and the lifecycle order come from config/bringup/real_robot_navigation_sim.yaml,
the file `amr-bringup real_robot_navigation_sim` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "real_robot_navigation_sim"


def generate_launch_description():
    return launch_description(BRINGUP)
