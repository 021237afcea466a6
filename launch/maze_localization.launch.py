"""ros2 launch amr_bringup maze_localization.launch.py: global localization while exploring: simulator, wall follower,
particle filter.

The nodes, their parameters and the lifecycle order come from config/bringup/maze_localization.yaml,
the file `amr-bringup maze_localization` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "maze_localization"


def generate_launch_description():
    return launch_description(BRINGUP)
