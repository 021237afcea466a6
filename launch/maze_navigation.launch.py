"""ros2 launch amr_bringup maze_navigation.launch.py: explore, localize, plan, go.

The nodes, their parameters and the lifecycle order come from config/bringup/maze_navigation.yaml,
the file `amr-bringup maze_navigation` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "maze_navigation"


def generate_launch_description():
    return launch_description(BRINGUP)
