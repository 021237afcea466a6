"""The LaunchDescription of a bringup file, for `ros2 launch` on a full ROS 2 Jazzy install.

launch and launch_ros are not on our registries: only the files in launch/ import this module,
and amr-bringup reads the same bringup YAML without them. The stack's arguments become launch
arguments (`ros2 launch amr_bringup maze_sim.launch.py --show-args`); the nodes are made when the
launch runs, by the same `Bringup.with_overrides` amr-bringup applies to its command line, so an
argument left unset changes nothing and both ways of starting a stack agree.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch_ros.actions import LifecycleNode, Node

from amr_bringup.stack_config import load_bringup


def launch_description(bringup_name: str) -> LaunchDescription:
    """The stack's arguments, then every node as a LifecycleNode and our lifecycle manager over them."""
    bringup = load_bringup(bringup_name)
    arguments = [
        DeclareLaunchArgument(
            name, default_value="", description=f"{argument.description} (unset: {bringup.current_value(name)!r})"
        )
        for name, argument in bringup.arguments.items()
    ]
    return LaunchDescription([*arguments, OpaqueFunction(function=_actions, args=[bringup_name])])


def _actions(context, bringup_name: str) -> list:
    """The nodes, with the arguments given to this launch applied."""
    bringup = load_bringup(bringup_name)
    given = {
        name: value
        for name, value in context.launch_configurations.items()
        if name in bringup.arguments and value != ""
    }
    bringup = bringup.with_overrides(given)
    nodes = [
        LifecycleNode(
            package=node.package,
            executable=node.executable,
            name=node.name,
            namespace=node.namespace,
            parameters=node.launch_parameters(),
            remappings=list(node.remappings),
            output="screen",
        )
        for node in bringup.nodes
    ]
    manager = Node(
        package="amr_bringup",
        executable="lifecycle_manager",
        name=bringup.manager_name,
        namespace="",
        parameters=[bringup.manager_parameters()],
        output="screen",
    )
    return [*nodes, manager]
