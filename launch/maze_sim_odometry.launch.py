"""ros2 launch amr_bringup maze_sim_odometry.launch.py: the maze in simulation through the odometry node.

Simulator (publishing /odom only), odometry node (/odom -> /odometry), wall follower.

The nodes, their parameters and the lifecycle order come from config/bringup/maze_sim_odometry.yaml,
the file `amr-bringup maze_sim_odometry` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "maze_sim_odometry"


def generate_launch_description():
    return launch_description(BRINGUP)
