"""ros2 launch amr_control maze_sim_odometry.launch.py: the maze in simulation through the odometry node.

Simulator (publishing /odom only), odometry node (/odom -> /odometry), wall follower.

The nodes, their parameters and the lifecycle order come from config/bringup/maze_sim_odometry.yaml,
the file `amr-bringup maze_sim_odometry` reads: one source for both ways of starting the stack.
"""

from launch import LaunchDescription
from launch_ros.actions import LifecycleNode, Node

from amr_control.bringup_config import load_bringup

BRINGUP = "maze_sim_odometry"


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
