"""ros2 launch amr_bringup real_robot_navigation.launch.py: a real TurtleBot3 navigating on a map (map:=PATH.yaml).

The nodes, their parameters and the lifecycle order come from config/bringup/real_robot_navigation.yaml,
the file `amr-bringup real_robot_navigation` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "real_robot_navigation"


def generate_launch_description():
    return launch_description(BRINGUP)
