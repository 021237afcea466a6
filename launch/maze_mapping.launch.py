"""ros2 launch amr_bringup maze_mapping.launch.py: map an unknown maze (slam, frontier exploration).

The nodes, their parameters and the lifecycle order come from config/bringup/maze_mapping.yaml,
the file `amr-bringup maze_mapping` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "maze_mapping"


def generate_launch_description():
    return launch_description(BRINGUP)
