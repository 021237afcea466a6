"""ros2 launch amr_bringup ik_service.launch.py: the IK service with config/ik_chains.yaml.

The nodes, their parameters and the lifecycle order come from config/bringup/ik_service.yaml,
the file `amr-bringup ik_service` reads: one source for both ways of starting the stack.
"""

from amr_bringup.launch_builder import launch_description

BRINGUP = "ik_service"


def generate_launch_description():
    return launch_description(BRINGUP)
