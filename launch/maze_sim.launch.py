"""ros2 launch amr_bringup maze_sim.launch.py: the maze in simulation: simulator and wall follower.

The nodes, their parameters and the lifecycle order come from config/bringup/maze_sim.yaml,
the file `amr-bringup maze_sim` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "maze_sim"


def generate_launch_description():
    return launch_description(BRINGUP)
