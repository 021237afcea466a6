"""The LaunchDescription of a bringup file, for `ros2 launch` on a full ROS 2 Jazzy install.

launch and launch_ros are not on our registries: only the files in launch/ import this module,
and amr-bringup reads the same bringup YAML without them.
"""

from launch import LaunchDescription
from launch_ros.actions import LifecycleNode, Node

from amr_control.bringup_config import load_bringup


def launch_description(bringup_name: str) -> LaunchDescription:
    """Every node of the bringup as a LifecycleNode, and our lifecycle manager over them."""
    bringup = load_bringup(bringup_name)
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
