"""ros2 launch amr_bringup real_robot_mapping.launch.py: map with a real TurtleBot3 (slam, frontier exploration).

The nodes, their parameters and the lifecycle order come from config/bringup/real_robot_mapping.yaml,
the file `amr-bringup real_robot_mapping` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "real_robot_mapping"


def generate_launch_description():
    return launch_description(BRINGUP)
