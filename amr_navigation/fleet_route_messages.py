"""amr_navigation.fleet_coordinator.Route <-> amr_interfaces/FleetRoute (each robot's /<robot>/fleet_route).

`route_message` writes a route (the fleet_planner node); `route_from_message` reads one back (the navigator) and
raises `RouteError` naming what is wrong with a garbage one: an unknown state, another frame, a FOLLOW without
waypoints, with more than MAX_ROUTE_POINTS or with one that is not finite. The navigator logs and refuses such a
route (the previous one stands); it never raises in its callback.
"""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time as TimeMessage
from geometry_msgs.msg import Point

from amr_interfaces.msg import FleetRoute
from amr_navigation.fleet_coordinator import FOLLOW, HOLD, NONE, Route

MAX_ROUTE_POINTS = 10000
"""a FOLLOW with more waypoints than this is refused."""


class RouteError(ValueError):
    """A fleet route that cannot be used (the reason names the field and the value)."""


def route_message(route: Route, stamp: TimeMessage, frame_id: str) -> FleetRoute:
    """The message of `route`, stamped `stamp` (the node clock)."""
    message = FleetRoute(
        state=route.state,
        final=route.final,
        plan=route.plan,
        progress=route.progress,
        total=route.total,
        reason=route.reason,
    )
    message.header.stamp, message.header.frame_id = stamp, frame_id
    message.waypoints = [Point(x=float(x), y=float(y)) for x, y in route.waypoints]
    return message


def route_from_message(message: FleetRoute, frame: str, lifetime: float = 0.0) -> Route:
    """The route in `message`, whose waypoints must be in `frame` (or unnamed); RouteError naming the problem. It
    expires `lifetime` s after its stamp (0: never)."""
    if message.state not in (NONE, HOLD, FOLLOW):
        raise RouteError(f"state {message.state[:40]!r} is not NONE, HOLD or FOLLOW")
    if message.header.frame_id not in ("", frame):
        raise RouteError(f"frame {message.header.frame_id!r}, expected {frame!r}")
    if message.state == FOLLOW:
        if not message.waypoints:
            raise RouteError("FOLLOW without waypoints")
        if len(message.waypoints) > MAX_ROUTE_POINTS:
            raise RouteError(f"{len(message.waypoints)} waypoints (at most {MAX_ROUTE_POINTS})")
        if not all(math.isfinite(p.x) and math.isfinite(p.y) for p in message.waypoints):
            raise RouteError("a waypoint is not finite")
    waypoints = np.array([(p.x, p.y) for p in message.waypoints], dtype=float).reshape(-1, 2)
    return Route(
        message.state,
        waypoints,
        bool(message.final),
        int(message.plan),
        int(message.progress),
        int(message.total),
        message.reason,
        message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec + lifetime if lifetime > 0.0 else math.inf,
    )
