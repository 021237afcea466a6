"""ros2 launch amr_bringup fleet_sim.launch.py: several robots in simulation: the simulator and one wall follower per
robot.

The nodes, their parameters and the lifecycle order come from config/bringup/fleet_sim.yaml,
the file `amr-bringup fleet_sim` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "fleet_sim"


def generate_launch_description():
    return launch_description(BRINGUP)
