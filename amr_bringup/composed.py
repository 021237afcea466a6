"""A stack composed in a caller's own rclpy context (tests, benchmarks): the node classes amr-bringup --composed
makes and the stack's lifecycle manager, each spun on a background thread of its own (amr_util.executors)."""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import replace

from rclpy.parameter import Parameter

from amr_bringup.bringup import node_class
from amr_bringup.lifecycle_manager import LifecycleManager
from amr_bringup.stack_config import load_bringup
from amr_util.executors import NodeSpinners


@contextmanager
def composed_stack(
    context,
    stack: str,
    arguments=None,
    parameters=None,
    remappings=None,
    extra_nodes=(),
    before_activate=lambda node: None,
    adjust=lambda bringup: bringup,
):
    """Yields (nodes by managed name: `simulator`, `/r1/wall_follower`, manager, spinners); the stack is built but
    not started (call manager.startup()). `remappings` by node name apply to every robot's copy of a per_robot node.
    `adjust` takes the stack as made and returns the one to start (a test's change the arguments cannot make)."""
    bringup = adjust(load_bringup(stack).with_overrides(arguments or {}, parameters or {}))
    specs = [
        replace(spec, remappings=spec.remappings + tuple((remappings or {}).get(spec.name, ())))
        for spec in bringup.nodes
    ]
    nodes = {spec.managed_name: node_class(spec)(context=context, cli_args=spec.ros_arguments()) for spec in specs}
    manager = LifecycleManager(
        before_activate=before_activate,
        context=context,
        cli_args=["--ros-args", "-r", f"__node:={bringup.manager_name}"],
        parameter_overrides=[Parameter(k, value=v) for k, v in bringup.manager_parameters().items()],
    )
    spinners = NodeSpinners(context)
    everything = [*nodes.values(), manager, *extra_nodes]
    for node in everything:
        spinners.add_node(node)
    try:
        yield nodes, manager, spinners
    finally:
        manager.shutdown()
        spinners.shutdown(timeout_sec=5.0)
        for node in everything:
            node.destroy_node()
