"""One planner, one costmap per robot: the navigator core asks the planner for every path it
drives, a fleet route's legs included, and holds no planner; the costmap its traffic rules read is the planner's
(amr_planning.costmap.shared_costmap: the nodes of one process given the same map and parameters hold one)."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from lifecycle_msgs.msg import Transition
from rclpy.parameter import Parameter

from amr_control.path_follower import PathFollower
from amr_maps.messages import grid_message
from amr_maps.occupancy_grid import OccupancyGrid
from amr_navigation.fleet_coordinator import FOLLOW, Route
from amr_navigation.loop import NavigationLoop
from amr_navigation.navigator import Controller, Navigator
from amr_navigation.navigator_core import HandOverCall, NavigatorCore, Observation, PlanAnswer, PlanCall
from amr_planning.costmap import Costmap, CostmapConfig, shared_costmap
from amr_planning.planner import Planner, PlannerConfig


def room() -> OccupancyGrid:
    """A free 2 x 3 m room at 0.05 m closed by a one-cell wall."""
    data = np.zeros((40, 60), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyGrid(data, 0.05, (0.0, 0.0, 0.0))


def route_job(core: NavigatorCore, waypoints) -> object:
    core.set_route(Route(FOLLOW, np.array(waypoints, dtype=float), final=True, plan=1, progress=0, total=2))
    return core.step(Observation(1.0, (0.5, 1.0, 0.0), True))


def test_a_fleet_routes_legs_are_asked_of_the_planner_one_by_one_a_failed_one_straight():
    core = NavigatorCore(Navigator((2.5, 1.0)))
    core.set_map(shared_costmap(room()))
    job = route_job(core, [(1.5, 1.0), (2.5, 1.5)])
    calls = [next(job)]
    first = np.array([[0.5, 1.0], [1.0, 1.1], [1.5, 1.0]])
    calls.append(job.send(PlanAnswer(first)))
    handed = job.send(PlanAnswer(None, "no path"))  # the second leg: straight
    assert [(c.start, c.goal, c.marks) for c in calls] == [
        ((0.5, 1.0), (1.5, 1.0), None),
        ((1.5, 1.0), (2.5, 1.5), None),
    ]
    assert isinstance(handed, HandOverCall)
    assert np.array_equal(handed.path, [[0.5, 1.0], [1.0, 1.1], [1.5, 1.0], [2.5, 1.5]])
    with pytest.raises(StopIteration) as stop:
        job.send("")
    assert stop.value.value.decision.controller is Controller.PATH_FOLLOWER


def test_without_the_planners_map_a_route_is_held_and_nothing_is_asked():
    core = NavigatorCore(Navigator((2.5, 1.0)))
    job = route_job(core, [(1.5, 1.0)])
    with pytest.raises(StopIteration) as stop:
        next(job)
    outcome = stop.value.value
    assert "fleet route without a map yet: holding" in outcome.events
    assert outcome.decision.reason == "holding: no map yet"


def test_the_library_loop_answers_the_legs_with_its_planner_whose_costmap_the_rules_read():
    planner = Planner(room(), PlannerConfig(resolution=0.05))
    loop = NavigationLoop(planner, None, PathFollower(), (2.5, 1.0))
    assert loop.planner is planner and loop.core.costmap is planner.costmap
    job = route_job(loop.core, [(1.5, 1.0), (2.5, 1.5)])
    call = next(job)
    while isinstance(call, PlanCall):
        call = job.send(loop._answer(call))
    expected = np.vstack([planner.plan((0.5, 1.0), (1.5, 1.0)), planner.plan((1.5, 1.0), (2.5, 1.5))[1:]])
    assert np.array_equal(call.path, expected)


def test_a_map_and_config_give_one_read_only_costmap_per_process():
    a, b = shared_costmap(room()), shared_costmap(room())  # two grids of the same cells
    assert a is b and not a.clearance.flags.writeable and not a.lethal.flags.writeable
    wider = shared_costmap(room(), CostmapConfig(robot_radius=0.2))
    assert wider is not a and wider.lethal.sum() > a.lethal.sum()
    assert np.array_equal(a.cost, Costmap(room()).cost)
    other = room()
    data = np.array(other.data)
    data[20, 30] = 100
    assert shared_costmap(OccupancyGrid(data, 0.05)) is not a


def test_the_planner_node_and_the_navigators_traffic_rules_hold_one_costmap(ros_context):
    from amr_navigation.navigator_node import NavigatorNode
    from amr_planning.planner_node import PlannerNode

    planner = PlannerNode(context=ros_context, namespace="/r1")
    navigator = NavigatorNode(
        context=ros_context, namespace="/r1", parameter_overrides=[Parameter("traffic", value=True)]
    )
    try:
        for node in (planner, navigator):
            assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
        message = grid_message(room(), Time(sec=1))
        planner._on_map(message)
        navigator._on_map(message)
        assert navigator.core.costmap is planner.planner.costmap
        assert not hasattr(navigator, "_map_planner") and getattr(navigator.core, "planner", None) is None
    finally:
        planner.destroy_node()
        navigator.destroy_node()
