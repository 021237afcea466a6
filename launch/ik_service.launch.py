"""ros2 launch amr_control ik_service.launch.py: the IK service with config/ik_chains.yaml.

The nodes, their parameters and the lifecycle order come from config/bringup/ik_service.yaml,
the file `amr-bringup ik_service` reads: one source for both ways of starting the stack.
"""

from launch import LaunchDescription
from launch_ros.actions import LifecycleNode, Node

from amr_control.bringup_config import load_bringup

BRINGUP = "ik_service"


def generate_launch_description() -> LaunchDescription:
    bringup = load_bringup(BRINGUP)
    nodes = [
        LifecycleNode(
            package=node.package, executable=node.executable, name=node.name, namespace=node.namespace,
            parameters=node.launch_parameters(), remappings=list(node.remappings), output="screen")
        for node in bringup.nodes
    ]
    manager = Node(
        package="amr_control", executable="lifecycle_manager", name=bringup.manager_name, namespace="",
        parameters=[bringup.manager_parameters()], output="screen")
    return LaunchDescription([*nodes, manager])
