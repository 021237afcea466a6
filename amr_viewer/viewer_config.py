"""The viewer node's parameters, stated once (its node and the parameter docs read them): no rclpy."""

from __future__ import annotations

from amr_util.parameter_spec import ParameterSpec
from amr_util.robot_description import default_robot


def specs() -> tuple[ParameterSpec, ...]:
    return (
        ParameterSpec(
            "host",
            "127.0.0.1",
            "address the web server binds: 127.0.0.1 (this machine only), or 0.0.0.0 "
            "for every interface (there is no authentication)",
        ),
        ParameterSpec(
            "port",
            8080,
            "port of the web server (0: any free port; a port in use fails configure)",
            minimum=0,
            maximum=65535,
        ),
        ParameterSpec("draw_period", 0.1, "wall-clock s between two redraws", minimum=0.02, maximum=10.0, live=True),
        ParameterSpec(
            "discovery_period", 1.0, "wall-clock s between two looks at the graph", minimum=0.1, maximum=60.0, live=True
        ),
        ParameterSpec(
            "max_particles",
            1000,
            "particles drawn at most (evenly picked from the cloud)",
            minimum=0,
            maximum=100000,
            live=True,
        ),
        ParameterSpec(
            "trail_spacing", 0.02, "m between two points of the trajectory trail", minimum=0.001, maximum=10.0
        ),
        ParameterSpec(
            "robot_radius",
            default_robot().radius,
            "m, the robot's drawn radius (the simulator's robot.radius "
            "when it has one; default: the robot description's)",
            minimum=0.01,
            maximum=10.0,
        ),
        ParameterSpec("namespaces", [], "robot namespaces to draw ([]: every one found)", kind="str_array"),
        ParameterSpec("map_frame", "map", "REP 105 map frame"),
        ParameterSpec("odom_frame", "odom", "REP 105 odometry frame"),
        ParameterSpec("base_frame", "base_footprint", "the robot's base frame"),
    )
