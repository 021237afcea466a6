"""ros2 launch amr_bringup real_robot.launch.py: a real TurtleBot3: odometry node and wall follower, no simulator.

The nodes, their parameters and the lifecycle order come from config/bringup/real_robot.yaml,
the file `amr-bringup real_robot` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "real_robot"


def generate_launch_description():
    return launch_description(BRINGUP)
