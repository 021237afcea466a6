"""ros2 launch amr_bringup fleet_navigation.launch.py: per robot explore, localize, plan, go to its own goal.

The nodes, their parameters and the lifecycle order come from config/bringup/fleet_navigation.yaml,
the file `amr-bringup fleet_navigation` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "fleet_navigation"


def generate_launch_description():
    return launch_description(BRINGUP)
