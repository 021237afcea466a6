"""ros2 launch amr_bringup real_robot_sim.launch.py: the real-robot stack rehearsed on the simulator.

The nodes, their parameters and the lifecycle order come from config/bringup/real_robot_sim.yaml,
the file `amr-bringup real_robot_sim` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "real_robot_sim"


def generate_launch_description():
    return launch_description(BRINGUP)
