"""Every simulated stack in real time: `mode:=realtime` runs the simulator on its timer, publishing
/clock, the nodes on simulated time and nobody waited for; each stack is composed here and run for a short while
until it has done its job for real (judged by the simulator's own ground truth, ~/status), within a wall-clock
deadline. real_robot_navigation_sim (always real time) reaches its goal in test_real_robot_navigation.py;
real_robot_mapping, which has no simulated twin, runs here with the simulator as its robot (on_the_simulator)."""

from __future__ import annotations

import math
import time
from contextlib import contextmanager
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, TwistStamped
from nav_msgs.msg import OccupancyGrid
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from support.ros import spin_until
from support.simulation import TWO_IN_THE_PILLAR_ROOM

from amr_bringup.composed import composed_stack
from amr_bringup.stack_config import load_bringup, shipped_stacks
from amr_control.navigated import stops_on_release
from amr_interfaces.msg import FleetRoute, NavigatorStatus, SimulatorStatus
from amr_util.lean_executor import LeanExecutor
from amr_util.qos import LATCHED

RELIABLE = QoSProfile(depth=200, reliability=ReliabilityPolicy.RELIABLE)
NAVIGATED = ("wall_follower", "path_follower")
"""the controllers a navigator hands the robot to: in real time they stop it when it gives the robot to nobody."""
STARTUP = 60.0
"""wall-clock s for a composed stack to come up on a loaded 2-core machine."""


class Watch(Node):
    """Each robot's simulator status (its ground truth's verdict) and fleet route, /map, and for one robot its
    commands and its navigator's statuses; publishes goals."""

    def __init__(self, context, robots=("",), navigated: bool = False) -> None:
        super().__init__("realtime_watch", context=context)
        self.status: dict[str, list[SimulatorStatus]] = {robot: [] for robot in robots}
        self.commands: list[TwistStamped] = []
        self.decisions: list[NavigatorStatus] = []
        self.maps: list[OccupancyGrid] = []
        self.routes: dict[str, list[FleetRoute]] = {robot: [] for robot in robots}
        for robot in robots:
            topic = f"/{robot}/status" if robot else "/simulator/status"
            self.create_subscription(SimulatorStatus, topic, self.status[robot].append, RELIABLE)
            if robot:
                self.create_subscription(FleetRoute, f"/{robot}/fleet_route", self.routes[robot].append, LATCHED)
        if navigated:  # one robot: its TwistStamped commands and its navigator's decisions
            self.create_subscription(TwistStamped, "/cmd_vel", self.commands.append, RELIABLE)
            self.create_subscription(NavigatorStatus, "/navigator/status", self.decisions.append, RELIABLE)
        self.create_subscription(OccupancyGrid, "/map", self.maps.append, LATCHED)
        self.goals = self.create_publisher(PoseStamped, "/goal_pose", RELIABLE)

    def last(self, robot: str = "") -> SimulatorStatus | None:
        return self.status[robot][-1] if self.status[robot] else None

    def sim_time(self, robot: str = "") -> float:
        last = self.last(robot)
        return last.sim_time if last is not None else 0.0

    def travelled(self, robot: str = "") -> float:
        last = self.last(robot)
        return last.distance_travelled if last is not None else 0.0

    def localized_errors(self, robot: str = "") -> list[float]:
        """m, the localizer's error at each localized /pose the simulator judged."""
        return [s.position_error for s in list(self.status[robot]) if s.localized and math.isfinite(s.position_error)]

    def send_goal(self, x: float, y: float) -> None:
        goal = PoseStamped()
        goal.header.frame_id = "map"
        goal.pose.position.x, goal.pose.position.y = x, y
        self.goals.publish(goal)


class Run:
    """A composed stack in real time with a Watch beside it; `until` spins until a condition or the deadline."""

    def __init__(self, context, nodes, manager, robots=("",), navigated: bool = False) -> None:
        self.nodes, self.manager = nodes, manager
        self.watch = Watch(context, robots, navigated)
        self.executor = LeanExecutor(context=context)
        self.executor.add_node(self.watch)
        self.started = time.monotonic()

    def start(self) -> None:
        steps = self.manager.startup()
        failed = [step.node for step in steps if not step.ok]
        assert not failed, {name: getattr(self.nodes.get(name), "configure_error", "") for name in failed}
        simulator = self.nodes["simulator"]
        assert simulator.get_parameter("mode").value == "realtime"
        self.started = time.monotonic()

    def until(self, condition, timeout: float) -> bool:
        return spin_until(self.executor, condition, timeout)

    def real_time_factor(self, robot: str = "") -> float:
        """simulated s per wall-clock s since the stack came up."""
        return self.watch.sim_time(robot) / max(time.monotonic() - self.started, 1e-9)

    def close(self) -> None:
        self.executor.remove_node(self.watch)
        self.executor.shutdown()
        self.watch.destroy_node()


@contextmanager
def running(
    context, stack: str, arguments=None, parameters=None, robots=("",), navigated: bool = False, adjust=lambda b: b
):
    """The stack composed in real time (`mode:=realtime`, or a stack that is real time only) and started: a Run.
    adjust: composed_stack's (a real robot's stack given the simulator as its robot)."""
    if "mode" in load_bringup(stack).arguments:
        arguments = {"mode": "realtime", **(arguments or {})}
    with composed_stack(context, stack, arguments=arguments, parameters=parameters, adjust=adjust) as (
        nodes,
        manager,
        _,
    ):
        run = Run(context, nodes, manager, robots, navigated)
        try:
            run.start()
            yield run
        finally:
            run.close()


# -- every simulated stack has the mode ---------------------------------------------------------------------------


def simulated_stacks() -> list[str]:
    return [name for name in shipped_stacks() if any(node.name == "simulator" for node in load_bringup(name).nodes)]


def test_every_simulated_stack_runs_in_real_time_by_one_argument():
    """`mode:=realtime` (a robot rehearsed on the simulator: real time always) sets the simulator's mode and the
    navigated controllers' stepping together: lockstep is a contract the stack declares to its nodes."""
    stacks, navigated = simulated_stacks(), set()
    assert {"maze_sim", "maze_localization", "maze_navigation", "maze_mapping", "fleet_navigation"} <= set(stacks)
    for name in stacks:
        bringup = load_bringup(name)
        if name.startswith("real_robot"):
            simulator = {node.name: node for node in bringup.nodes}["simulator"]
            assert simulator.parameters["mode"] == "realtime", name
            assert "mode" not in bringup.arguments, f"{name}: a robot rehearsed is real time only"
            continue
        assert "mode" in bringup.arguments, f"{name}: no mode argument"
        for mode in ("realtime", "lockstep"):
            arguments = {"mode": mode} | ({"world": "fleets/crossing.yaml"} if bringup.robots_from else {})
            nodes = bringup.with_overrides(arguments).nodes
            for node in nodes:
                if node.name == "simulator":
                    assert node.parameters["mode"] == mode, name
                if node.name in NAVIGATED and node.parameters.get("navigated"):
                    assert node.parameters["stepping"] == mode, (name, node.managed_name)
                    navigated.add(name)
    assert navigated == {"maze_navigation", "maze_mapping", "fleet_navigation"}


def test_a_released_controller_stops_the_robot_unless_the_zero_would_step_a_lockstep_world():
    nobody, other = SimpleNamespace(controller=""), SimpleNamespace(controller="path_follower")
    for stepping in ("lockstep", "realtime"):  # a timer-driven controller (a real robot's) always stops it
        assert stops_on_release(False, stepping, nobody) and stops_on_release(False, stepping, other)
    assert stops_on_release(True, "realtime", nobody), "real time: the zero is the hold"
    assert not stops_on_release(True, "realtime", other), "the other controller's command answers the observation"
    assert not stops_on_release(True, "lockstep", nobody), "lockstep: a zero would step the world"


# -- the wall-follower stacks ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("stack", ["maze_sim", "maze_sim_odometry", "real_robot_sim"])
def test_a_wall_follower_stack_drives_in_real_time(ros_context, stack):
    """The simulator steps on its timer (simulated time goes at about the pace) and the wall follower drives the
    robot along the walls without touching one."""
    with running(ros_context, stack, parameters={"simulator.pace": "2.0"}) as run:
        _drives(run)


def _drives(run: Run) -> None:
    watch = run.watch
    assert run.until(lambda: watch.travelled() > 0.6, 40.0), (
        f"travelled {watch.travelled():.2f} m in {watch.sim_time():.1f} simulated s"
    )
    assert watch.last().collisions == 0
    assert 0.5 < run.real_time_factor() < 3.0, f"{run.real_time_factor():.2f}x real time, asked 2x"


def test_fleet_sim_drives_every_robot_in_real_time(ros_context, tmp_path):
    world = tmp_path / "two.yaml"
    world.write_text(TWO_IN_THE_PILLAR_ROOM)
    with running(ros_context, "fleet_sim", {"world": str(world)}, {"simulator.pace": "2.0"}, ("r1", "r2")) as run:
        watch = run.watch
        assert run.until(lambda: all(watch.travelled(r) > 0.5 for r in ("r1", "r2")), 40.0), [
            watch.travelled(r) for r in ("r1", "r2")
        ]
        assert [watch.last(r).collisions for r in ("r1", "r2")] == [0, 0]


# -- localization, navigation, mapping -------------------------------------------------------------------------------


def test_maze_localization_localizes_in_real_time(ros_context):
    """The filter, out of the loop (nobody waits for its /pose), localizes the robot the wall follower explores
    with: its estimates within 10 cm of the ground truth."""
    with running(ros_context, "maze_localization") as run:
        watch = run.watch
        assert run.until(lambda: len(watch.localized_errors()) >= 40, 60.0), (
            f"{len(watch.localized_errors())} localized /pose in {watch.sim_time():.1f} simulated s"
        )
        errors = watch.localized_errors()
        assert max(errors[-10:]) < 0.10, errors
        assert watch.last().collisions == 0


def test_maze_navigation_holds_explicitly_and_reaches_its_goal_in_real_time(ros_context):
    """Exploring, localized, following: a goal refused mid-path gives the robot to nobody, and the path follower
    stops it with a zero command at once (not the simulator's command timeout: time goes on and the robot stands);
    the world's goal given again is reached, with no collision."""
    with running(ros_context, "maze_navigation", navigated=True) as run:
        watch = run.watch
        assert run.until(lambda: _named(watch, "path_follower"), 60.0), (
            f"no path followed by {watch.sim_time():.1f} simulated s"
        )
        assert run.until(lambda: _moving(watch), 10.0), "the path follower did not drive"
        watch.send_goal(0.0, 0.0)  # inside the pillar: refused, nobody drives
        assert run.until(lambda: any(d.mode == "NO_PATH" for d in watch.decisions[-3:]), 10.0)
        released = watch.sim_time()
        assert run.until(lambda: watch.sim_time() > released + 1.0, 10.0), "time went on"
        held = [s for s in watch.status[""] if s.sim_time > released + 0.3]
        assert held, "statuses while held"
        assert max(s.distance_travelled for s in held) - min(s.distance_travelled for s in held) < 0.005, (
            "the robot stood while nobody drove"
        )
        after = [c for c in watch.commands if _seconds(c) > released - 0.2]
        assert after and after[-1].twist.linear.x == 0.0 and after[-1].twist.angular.z == 0.0, (
            "an explicit zero command stopped it"
        )
        watch.send_goal(0.0, -0.4)  # the world's (pillar_goal): south of the pillar
        assert run.until(lambda: watch.last().goal_reached, 60.0), (
            f"no goal by {watch.sim_time():.1f} simulated s, {watch.travelled():.2f} m"
        )
        assert watch.last().collisions == 0
        assert max(watch.localized_errors()[-10:]) < 0.10


def test_maze_mapping_grows_its_map_in_real_time(ros_context):
    """slam, out of the loop, builds /map while the explorer's goals drive the robot; its /pose stays near the
    ground truth (the simulator judges it in the start's frame)."""
    with running(ros_context, "maze_mapping") as run:
        watch = run.watch
        assert run.until(lambda: watch.maps, 30.0), "no /map"
        first = _known(watch.maps[0])
        assert run.until(lambda: watch.travelled() > 1.5 and _known(watch.maps[-1]) > 1.5 * first, 60.0), (
            f"map {first} -> {_known(watch.maps[-1])} cells, travelled {watch.travelled():.2f} m"
        )
        errors = watch.localized_errors()
        assert errors and max(errors) < 0.15, errors[-10:]
        assert watch.last().collisions == 0


def on_the_simulator(world: str):
    """A real robot's stack (no simulator: the robot's bringup gives /scan, /odom) given the simulator in real time as
    its robot, as real_robot_navigation_sim is real_robot_navigation's: that stack's simulator (the LDS-01's 360 beams
    at 5 Hz, pose-only /odom at 20 Hz, plain Twist, noise) on `world`, every node on its /clock, the seed's sign flip
    off (the simulator follows REP 103)."""

    def adjust(bringup):
        twin = {node.name: node for node in load_bringup("real_robot_navigation_sim").nodes}["simulator"]
        simulator = replace(twin, parameters={**twin.parameters, "world": world})
        nodes = []
        for node in bringup.nodes:
            parameters = {**node.parameters, "use_sim_time": True}
            if "flip_angular_sign" in parameters or node.name in NAVIGATED:
                parameters["flip_angular_sign"] = False
            nodes.append(replace(node, parameters=parameters))
        return replace(
            bringup, nodes=(*nodes, simulator), node_startup_order=(*bringup.node_startup_order, "simulator")
        )

    return adjust


def test_real_robot_mapping_grows_its_map_on_the_simulator_in_real_time(ros_context):
    """real_robot_mapping (odometry node, slam, planner, the real path follower on its timer, navigator, explorer)
    with the simulator as its robot: slam's /map grows while the explorer's goals drive the robot, its /pose near the
    ground truth, no collision; the stack's real-robot configurations on a real robot's sensor rates."""
    with running(ros_context, "real_robot_mapping", adjust=on_the_simulator("inner_maze.yaml")) as run:
        watch = run.watch
        assert run.until(lambda: watch.maps, 30.0), "no /map"
        first = _known(watch.maps[0])
        assert run.until(lambda: watch.travelled() > 1.5 and _known(watch.maps[-1]) > 1.5 * first, 90.0), (
            f"map {first} -> {_known(watch.maps[-1])} cells, travelled {watch.travelled():.2f} m"
        )
        errors = watch.localized_errors()
        assert errors and max(errors) < 0.15, errors[-10:]
        assert watch.last().collisions == 0


def test_fleet_navigation_localizes_and_drives_two_robots_in_real_time(ros_context, tmp_path):
    """Two robots, each with its filter, planner, navigator and controllers, and one fleet planner: both localized
    within 10 cm and moving without a collision, then each handed its route of the fleet plan."""
    world = tmp_path / "two.yaml"
    world.write_text(TWO_IN_THE_PILLAR_ROOM)
    robots = ("r1", "r2")
    with running(ros_context, "fleet_navigation", {"world": str(world)}, robots=robots) as run:
        watch = run.watch
        assert run.until(
            lambda: all(len(watch.localized_errors(r)) >= 10 and watch.travelled(r) > 0.5 for r in robots), 90.0
        ), {r: (len(watch.localized_errors(r)), watch.travelled(r)) for r in robots}
        for r in robots:
            assert max(watch.localized_errors(r)[-5:]) < 0.10, (r, watch.localized_errors(r)[-5:])
            assert watch.last(r).collisions == 0, r
        assert run.until(lambda: all(any(m.state == "FOLLOW" for m in watch.routes[r]) for r in robots), 30.0), {
            r: [m.state for m in watch.routes[r]] for r in robots
        }  # the fleet planned together (coordination: plan), each robot handed its route


# -- helpers --------------------------------------------------------------------------------------------------------


def _seconds(message) -> float:
    return message.header.stamp.sec + message.header.stamp.nanosec * 1e-9


def _named(watch: Watch, controller: str) -> bool:
    return any(d.controller == controller for d in watch.decisions[-3:])


def _moving(watch: Watch) -> bool:
    recent = watch.commands[-3:]
    return bool(recent) and any(abs(c.twist.linear.x) > 0.01 or abs(c.twist.angular.z) > 0.01 for c in recent)


def _known(grid: OccupancyGrid) -> int:
    return int(np.count_nonzero(np.asarray(grid.data) >= 0))
