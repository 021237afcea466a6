"""The traffic rules through ROS: the fleet_navigation stack, composed, on two robots face to face in a
corridor one robot wide with a side pocket (tests/navigation/test_traffic.py's world at library level). With the
rules (the stack's default) both reach their goals without touching each other; with `traffic: false` the same
world deadlocks or they collide, so the test can fail. A relay stands in for the particle filters (each robot's
ground truth as its /<name>/pose, localized), as the library test runs with localization "truth"."""

from __future__ import annotations

import time
from dataclasses import replace

from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from support.ros import spin_until

from amr_bringup.composed import composed_stack
from amr_interfaces.msg import LocalizedPose, SimulatorStatus
from amr_util.lean_executor import LeanExecutor

RELIABLE = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
FLEET_PLANNER = "fleet_planner"
ROBOTS = ("r1", "r2")
STARTUP = 40.0
"""s of wall clock for the stack to come up (a loaded 2-core machine)."""
SIM_LIMIT = 60.0
"""s of simulated time: the run takes about 32 s here (r2 going aside into the pocket), as at library level."""
STALLED = 15.0
"""s of wall clock without simulated time going on: the world is held (a deadlock through ROS)."""
WALL_LIMIT = 150.0
"""s of wall clock at most for the run (it ends as soon as both robots are at their goals)."""
STOOD_STILL = 20.0
"""s of simulated time in which no robot moved (1 cm): a deadlock, decided (longer than any of the stack's waits:
plan_timeout 10 s, the fleet planner's stuck_time 15 s); the run without the rules ends there, not at SIM_LIMIT
(its robots stop face to face at about 8 s)."""


def corridor_yaml(pocket_x: float = 0.8, length: float = 2.0) -> str:
    """tests/navigation/test_traffic.py's corridor(pocket_x): 0.35 m free, a pocket 0.35 m wide at pocket_x on
    the +y side; r1 from the -x end to the +x end, r2 the other way."""
    side = 0.7
    walls = [
        [-length, -0.2, length, -0.2],
        [-length, 0.2, pocket_x - 0.2, 0.2],
        [pocket_x + 0.2, 0.2, length, 0.2],
        [pocket_x - 0.2, 0.2, pocket_x - 0.2, side],
        [pocket_x + 0.2, 0.2, pocket_x + 0.2, side],
        [-length, -0.2, -length, 0.2],
        [length, -0.2, length, 0.2],
        [pocket_x - 0.2, side, pocket_x + 0.2, side],
    ]
    lines = ["name: corridor_with_a_pocket", "wall_thickness: 0.05", "walls:"]
    lines += [f"  - [{', '.join(f'{v:g}' for v in wall)}]" for wall in walls]
    lines += [
        "robots:",
        "  - name: r1",
        f"    start: [{-length + 0.3:g}, 0.0, 0.0]",
        f"    goal: [{length - 0.3:g}, 0.0, 0.1]",
        "  - name: r2",
        f"    start: [{length - 0.3:g}, 0.0, 3.14159265358979]",
        f"    goal: [{-length + 0.3:g}, 0.0, 0.1]",
    ]
    return "\n".join(lines) + "\n"


ROOM = """\
name: room{suffix}
wall_thickness: 0.05
walls:
  - [-1.5, -0.75, 1.5, -0.75]
  - [1.5, -0.75, 1.5, 0.75]
  - [1.5, 0.75, -1.5, 0.75]
  - [-1.5, 0.75, -1.5, -0.75]
{boxes}robots:
  - name: r1
    start: [-1.1, 0.0, 0.0]
    goal: [1.1, 0.0, 0.1]
"""


class Truth(Node):
    """Each robot's ground truth relayed as its /<name>/pose (localized, same stamp), and its simulator status."""

    def __init__(self, context, robots=ROBOTS) -> None:
        super().__init__("fleet_traffic_truth", context=context)
        self.robots = robots
        self.status: dict[str, SimulatorStatus] = {}
        self.publishers_ = {r: self.create_publisher(LocalizedPose, f"/{r}/pose", RELIABLE) for r in robots}
        self.keep = []
        for r in robots:
            self.keep += [
                self.create_subscription(Odometry, f"/{r}/ground_truth", lambda m, r=r: self._relay(r, m), RELIABLE),
                self.create_subscription(
                    SimulatorStatus, f"/{r}/status", lambda m, r=r: self.status.__setitem__(r, m), RELIABLE
                ),
            ]

    def _relay(self, robot: str, truth: Odometry) -> None:
        message = LocalizedPose(localized=True)
        message.header = truth.header
        message.pose = truth.pose
        self.publishers_[robot].publish(message)

    def reached(self) -> int:
        return sum(1 for r in self.robots if r in self.status and self.status[r].goal_reached)

    def robot_contacts(self) -> int:
        return sum(status.robot_collisions for status in self.status.values())

    def sim_time(self) -> float:
        return min((status.sim_time for status in self.status.values()), default=0.0)

    def travelled(self, robot: str) -> float:
        """m the robot has driven (ground truth), 0 before its first status."""
        return self.status[robot].distance_travelled if robot in self.status else 0.0


def run_corridor(
    ros_context, tmp_path, traffic: bool, stood_still: float | None = None
) -> tuple[int, int, float, dict]:
    """(robots at their goals, robot-robot contacts, simulated s) of one run; both navigators' traffic counters."""
    world = tmp_path / "corridor.yaml"
    world.write_text(corridor_yaml())
    reached, contacts, _, sim_time, detail = run_stack(
        ros_context, world, None, ROBOTS, traffic, stood_still=stood_still
    )
    return reached, contacts, sim_time, detail


def run_stack(
    ros_context, world, map_world, robots, traffic: bool, coordination: str = "rules", stood_still: float | None = None
) -> tuple[int, int, int, float, dict]:
    """(robots at their goals, robot-robot contacts, wall contacts, simulated s, {wall: s, robot: its traffic
    counters, plans: the fleet planner's, still: the simulated s no robot had moved at the end}) of one run of
    fleet_navigation on `world` (the map made of `map_world` when given). With `stood_still`, the run also ends once
    no robot has moved for that many simulated s (a deadlock)."""
    away = (("pose", "particle_filter_unused/pose"), ("scan", "particle_filter_unused/scan"))
    parameters = {
        "simulator.lockstep_resend_period": "0.5",
        "navigator.traffic": str(traffic).lower(),
        "navigator.coordination": coordination,
    }

    def the_map(bringup):  # the map of another world than the simulator's (one without a box)
        if map_world is None:
            return bringup
        nodes = tuple(
            replace(node, parameters={**node.parameters, "world": str(map_world)})
            if node.name == "map_server"
            else node
            for node in bringup.nodes
        )
        return replace(bringup, nodes=nodes)

    with composed_stack(
        ros_context,
        "fleet_navigation",
        arguments={"world": str(world)},
        parameters=parameters,
        remappings={"particle_filter": away},
        adjust=the_map,
    ) as (nodes, manager, _):
        truth = Truth(ros_context, robots)
        executor = LeanExecutor(context=ros_context)
        executor.add_node(truth)
        try:
            assert all(step.ok for step in manager.startup()), "fleet_navigation did not come up"
            started = time.monotonic()
            progress = [0.0, started]  # the world held (nobody answering an observation) is a deadlock too
            # the robots' distances travelled at their last move, and its simulated time
            moved = [(0.0,) * len(robots), 0.0]

            def over() -> bool:
                now, sim = time.monotonic(), truth.sim_time()
                if sim > progress[0]:
                    progress[:] = [sim, now]
                travelled = tuple(truth.travelled(r) for r in robots)
                if max(abs(a - b) for a, b in zip(travelled, moved[0], strict=True)) > 0.01:
                    moved[:] = [travelled, sim]
                return (
                    truth.reached() == len(robots)
                    or truth.robot_contacts() > 0
                    or sim >= SIM_LIMIT
                    or now - progress[1] > STALLED
                    or (stood_still is not None and sim - moved[1] >= stood_still)
                )

            spin_until(executor, over, WALL_LIMIT)
            wall = time.monotonic() - started
        finally:
            executor.remove_node(truth)
            executor.shutdown()
        counters = {r: nodes[f"/{r}/navigator"].traffic.counters if traffic else None for r in robots}
        counters["plans"] = nodes[FLEET_PLANNER].coordinator.plans
        counters["cut"] = list(nodes[FLEET_PLANNER].coordinator.cut)
        walls = sum(status.wall_collisions for status in truth.status.values())
        detail = {"wall": wall, "still": truth.sim_time() - moved[1], **counters}
        result = truth.reached(), truth.robot_contacts(), walls, truth.sim_time(), detail
        truth.destroy_node()
    return result


def test_two_robots_face_to_face_in_a_one_wide_corridor_pass_through_ros(ros_context, tmp_path):
    reached, contacts, sim_time, detail = run_corridor(ros_context, tmp_path, traffic=True)
    print(f"traffic on: {reached} reached, {contacts} contacts, {sim_time:.1f} s simulated, {detail}")
    assert contacts == 0, detail
    assert reached == 2, (sim_time, detail)
    assert detail["r2"].yields >= 1 and detail["r1"].yields == 0, detail  # r2 (second in the list) gives way
    assert detail["plans"] == 0, detail  # coordination rules: no navigator listens to a route, nothing is planned


def test_planned_together_the_two_robots_pass_through_the_pocket_through_ros(ros_context, tmp_path):
    """coordination:=plan: the fleet_planner plans both robots as soon as both are localized (at once here), and
    the navigators follow their routes (one waits in the pocket) without the traffic rules ever acting."""
    world = tmp_path / "corridor.yaml"
    world.write_text(corridor_yaml())
    reached, contacts, walls, sim_time, detail = run_stack(ros_context, world, None, ROBOTS, True, "plan")
    print(f"planned: {reached} reached, {contacts} contacts, {sim_time:.1f} s simulated, {detail}")
    assert contacts == 0 and walls == 0, detail
    assert reached == 2, (sim_time, detail)
    assert detail["plans"] == 1, detail
    assert all(detail[r].yields == 0 and detail[r].stops == 0 for r in ROBOTS), detail  # the plan, not the rules


def test_without_the_rules_the_corridor_deadlocks_or_collides_through_ros(ros_context, tmp_path):
    """Deadlocked is decided once neither robot has moved for STOOD_STILL simulated s (or at SIM_LIMIT)."""
    reached, contacts, sim_time, detail = run_corridor(ros_context, tmp_path, traffic=False, stood_still=STOOD_STILL)
    print(f"traffic off: {reached} reached, {contacts} contacts, {sim_time:.1f} s simulated, {detail}")
    assert reached < 2 or contacts > 0, (reached, contacts, sim_time, detail)


def test_a_box_not_on_the_map_stops_the_robot_which_replans_around_it_through_the_planner_node(ros_context, tmp_path):
    world, known = tmp_path / "room_box.yaml", tmp_path / "room.yaml"
    world.write_text(ROOM.format(suffix="_box", boxes="boxes:\n  - [-0.1, -0.15, 0.1, 0.15]\n"))
    known.write_text(ROOM.format(suffix="", boxes=""))
    reached, _, walls, sim_time, detail = run_stack(ros_context, world, known, ("r1",), traffic=True)
    print(f"box: {reached} reached, {walls} wall contacts, {sim_time:.1f} s simulated, {detail}")
    assert reached == 1 and walls == 0, (sim_time, detail)  # the box is a solid: touching it is a wall contact
    assert detail["r1"].stops >= 1 and detail["r1"].replans_around >= 1, detail


def test_planned_together_a_box_not_on_the_map_gets_its_edge_cut_and_the_robot_planned_around_it(ros_context, tmp_path):
    """coordination:=plan, a box the map does not hold across the robot's planned way: its path follower stops for
    it, the fleet planner cuts the lattice edge after stuck_time and plans again, and the robot goes round."""
    world, known = tmp_path / "room_box.yaml", tmp_path / "room.yaml"
    world.write_text(ROOM.format(suffix="_box", boxes="boxes:\n  - [-0.1, -0.15, 0.1, 0.15]\n"))
    known.write_text(ROOM.format(suffix="", boxes=""))
    reached, _, walls, sim_time, detail = run_stack(ros_context, world, known, ("r1",), True, "plan")
    print(f"box, planned: {reached} reached, {walls} wall contacts, {sim_time:.1f} s simulated, {detail}")
    assert reached == 1 and walls == 0, (sim_time, detail)
    assert detail["plans"] >= 2 and detail["cut"], detail
