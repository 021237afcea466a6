"""Fleet speed: steps per second with 1, 5, 10 and 20 robots, at library level side by side with IR-SIM, and
through ROS in lockstep.

    python bench/bench_fleet.py [--steps 400] [--repeats 3] [--irsim-python /path/to/python] [--profile 10]
    python bench/bench_fleet.py --ros [--ros-steps 400] [--counts 1 5 10 20]

The scene: an 8 m x 6 m room (walls 5 cm thick) with four boxes; N TurtleBot3-like robots start on
a grid of free points with seeded headings. Every robot has a 240-beam 360-degree LiDAR (3.5 m)
and drives by a bump-and-turn rule from its own scan (ahead at 0.2 m/s; turning on the spot while
something is within 0.3 m in the front 45 degrees), so robots meet walls and each other. The
simulator runs with its config defaults (dt = 0.05 s, LiDAR noise 0.01 m, numpy ray casting); only
Fleet.step() is timed (the rule runs outside the timer), the best of `repeats` identical runs: the
process's CPU time (time.process_time) and, apart, the wall clock (which other processes on a shared
machine inflate; on a quiet machine the two agree).

IR-SIM 2.12 runs the same scene (same boxes, robots, starts, radius, beams, range, dt, the same rule
from its own scans, only env.step() timed, headless, its LiDAR noise off) in the same run of this
script: in this interpreter if it imports ir-sim, else in the interpreter given by --irsim-python
(a scratch venv: `python -m venv /tmp/irsim && /tmp/irsim/bin/pip install ir-sim==2.12.0`), else
it is skipped with a message.

--ros: the same scene through ROS 2, composed: the simulator node (lockstep, every topic on: /clock, and per
robot odometry, odom, ground_truth, scan, status, tf) and one driver node per robot in the robot's namespace
(/r0/..., as fleet_sim's wall followers), all in this process on one single-threaded executor. Each driver
answers its robot's observation (odometry and scan of one stamp) with the bump-and-turn command on
/<robot>/cmd_vel; the world steps when every robot's command is in. Timed: the wall clock and this process's
CPU time from the first command to the last observation (the driver's rule included: it is the loop's), after
`--ros-warmup` steps, the best of `repeats` runs. --ros-lean adds runs with only /clock, odometry and scan published.
--ros-executor events runs them on rclpy's experimental EventsExecutor instead (a comparison: the suite's nodes spin on
the SingleThreadedExecutor).
"""

from __future__ import annotations

import argparse
import cProfile
import importlib.util
import json
import math
import os
import pstats
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"  # before rclpy: no traffic leaves this machine
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(101, 232)))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from amr_maps.world import World, load_world, resolve_world_path, world_from_dict  # noqa: E402
from amr_simulation.config import SimulationConfig  # noqa: E402
from amr_simulation.fleet import Fleet  # noqa: E402
from amr_util.environment import child_environment  # noqa: E402
from amr_util.geometry import wrap_angle  # noqa: E402

HERE = Path(__file__).resolve().parent
COUNTS = (1, 5, 10, 20)
EXTENT = (-4.0, -3.0, 4.0, 3.0)
WALL = 0.05
OBSTACLES = ([-2.3, -1.7, -1.7, -1.3], [1.7, 1.3, 2.3, 1.7], [-0.3, -0.3, 0.3, 0.3], [1.4, -1.9, 2.0, -1.3])


def scene(counts: tuple[int, ...], steps: int, repeats: int) -> dict:
    """The room, its robots' starts and the sensor and drive figures both simulators get."""
    config = SimulationConfig()
    xmin, ymin, xmax, ymax = EXTENT
    walls = [
        [xmin, ymin, xmax, ymin + WALL],
        [xmin, ymax - WALL, xmax, ymax],
        [xmin, ymin + WALL, xmin + WALL, ymax - WALL],
        [xmax - WALL, ymin + WALL, xmax, ymax - WALL],
    ]
    boxes = walls + [list(b) for b in OBSTACLES]
    rng = np.random.default_rng(0)
    free = [
        (x, y)
        for x in np.arange(xmin + 0.6, xmax - 0.5, 0.8)
        for y in np.arange(ymin + 0.6, ymax - 0.5, 0.8)
        if all(not (b[0] - 0.35 < x < b[2] + 0.35 and b[1] - 0.35 < y < b[3] + 0.35) for b in OBSTACLES)
    ]
    order = rng.permutation(len(free))[: max(counts)]
    starts = [
        [round(float(free[i][0]), 3), round(float(free[i][1]), 3), round(float(rng.uniform(-math.pi, math.pi)), 3)]
        for i in order
    ]
    return {
        "extent": list(EXTENT),
        "boxes": boxes,
        "starts": starts,
        "radius": config.robot.radius,
        "max_linear": config.robot.max_linear,
        "max_angular": config.robot.max_angular,
        "beams": config.lidar.beams,
        "range_min": config.lidar.range_min,
        "range_max": config.lidar.range_max,
        "dt": config.dt,
        "steps": steps,
        "repeats": repeats,
        "counts": list(counts),
    }


def world(description: dict, count: int) -> World:
    robots = [{"name": f"r{i}", "start": start} for i, start in enumerate(description["starts"][:count])]
    return world_from_dict({"boxes": description["boxes"], "robots": robots}, source=f"bench room, {count} robots")


def bump_and_turn(ranges: np.ndarray) -> tuple[float, float]:
    """Ahead at 0.2 m/s; on the spot at 1.5 rad/s while a return within 0.3 m lies in the front 45 deg."""
    n = ranges.size
    front = np.concatenate([ranges[: n // 16 + 1], ranges[-(n // 16) :]])
    return (0.0, 1.5) if np.any(np.abs(front) < 0.3) else (0.2, 0.0)


def run(description: dict, count: int) -> dict:
    """Best-of-repeats seconds spent in Fleet.step over the scene's steps."""
    best, best_wall, collisions = math.inf, math.inf, (0, 0)
    for _ in range(description["repeats"]):
        fleet = Fleet(world(description, count))
        cpu = wall = 0.0
        for _ in range(description["steps"]):
            commands = [bump_and_turn(np.asarray(robot.ranges)) for robot in fleet.robots]
            start, start_wall = time.process_time(), time.perf_counter()
            fleet.step(commands)
            cpu += time.process_time() - start
            wall += time.perf_counter() - start_wall
        best, best_wall = min(best, cpu), min(best_wall, wall)
        collisions = (
            sum(r.wall_collisions for r in fleet.robots),
            sum(sum(r.robot_collisions.values()) for r in fleet.robots) // 2,
        )
    return {
        "robots": count,
        "seconds": best,
        "wall": best_wall,
        "steps": description["steps"],
        "collisions": collisions,
    }


def world_file(description: dict, count: int, directory: Path) -> Path:
    """The scene with `count` robots as a world file, for the simulator node's `world` parameter."""
    robots = [{"name": f"r{i}", "start": start} for i, start in enumerate(description["starts"][:count])]
    path = directory / f"bench_room_{count}.yaml"
    path.write_text(yaml.safe_dump({"name": f"bench_room_{count}", "boxes": description["boxes"], "robots": robots}))
    return path


LEAN = {
    "publish_odom": False,
    "publish_ground_truth": False,
    "publish_status": False,
    "publish_tf": False,
    "publish_clock": True,
}
"""--ros-lean: the simulator publishes /clock and each robot's odometry and scan only (what its driver reads)."""


def ros_run(
    description: dict, count: int, steps: int, warmup: int, lean: bool = False, executor_kind: str = "single"
) -> dict:
    """The simulator node and `count` drivers composed on one executor (rclpy's SingleThreadedExecutor, or with
    "events" rclpy's experimental EventsExecutor); wall and CPU seconds for `steps` steps."""
    import rclpy
    from geometry_msgs.msg import TwistStamped
    from nav_msgs.msg import Odometry
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
    from sensor_msgs.msg import LaserScan

    from amr_simulation.simulator_node import SimulatorNode

    class Driver(Node):
        """One robot's controller: answers odometry + scan of one stamp with the bump-and-turn command."""

        def __init__(self, context, robot: str) -> None:
            super().__init__("driver", namespace=robot, context=context)
            reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
            self.cmd_vel = self.create_publisher(TwistStamped, "cmd_vel", reliable)
            self.odometry = self.create_subscription(Odometry, "odometry", self._on_odometry, reliable)
            self.scan = self.create_subscription(LaserScan, "scan", self._on_scan, qos_profile_sensor_data)
            self.observations = 0
            self._stamps = [None, None]
            self._command = (0.2, 0.0)

        def _on_odometry(self, message: Odometry) -> None:
            self._stamps[0] = (message.header.stamp.sec, message.header.stamp.nanosec)
            self._answer()

        def _on_scan(self, message: LaserScan) -> None:
            self._stamps[1] = (message.header.stamp.sec, message.header.stamp.nanosec)
            self._command = bump_and_turn(np.asarray(message.ranges, dtype=float))
            self._answer()

        def _answer(self) -> None:
            if self._stamps[0] is None or self._stamps[0] != self._stamps[1]:
                return
            self._stamps = [None, None]
            self.observations += 1
            self.send()

        def send(self) -> None:
            message = TwistStamped()
            message.twist.linear.x, message.twist.angular.z = self._command
            self.cmd_vel.publish(message)

        def connected(self) -> bool:
            return (
                self.cmd_vel.get_subscription_count() > 0
                and self.odometry.get_publisher_count() > 0
                and self.scan.get_publisher_count() > 0
            )

    context = rclpy.Context()
    rclpy.init(context=context)
    if executor_kind == "events":
        from rclpy.experimental import EventsExecutor

        executor = EventsExecutor(context=context)
    else:
        executor = SingleThreadedExecutor(context=context)
    with tempfile.TemporaryDirectory() as directory:
        path = world_file(description, count, Path(directory))
        node = SimulatorNode(
            context=context,
            parameter_overrides=[
                Parameter("world", value=str(path)),
                Parameter("lockstep_resend_period", value=0.0),
                *(Parameter(name, value=value) for name, value in (LEAN if lean else {}).items()),
            ],
        )
        drivers = [Driver(context, f"r{i}") for i in range(count)]
        try:
            for each in (node, *drivers):
                executor.add_node(each)
            node.trigger_configure()
            deadline = time.monotonic() + 30.0
            while not all(d.connected() for d in drivers) and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            node.trigger_activate()  # the first observation: every driver answers, the loop runs
            marks = {}
            last, last_progress = -1, time.monotonic()
            while True:
                done = min(d.observations for d in drivers)
                if done >= warmup and "start" not in marks:
                    marks["start"] = (done, time.perf_counter(), time.process_time())
                if done >= warmup + steps:
                    marks["end"] = (done, time.perf_counter(), time.process_time())
                    break
                if done != last:
                    last, last_progress = done, time.monotonic()
                elif time.monotonic() - last_progress > 10.0:
                    raise RuntimeError(f"{count} robots: the loop stalled after {done} steps")
                executor.spin_once(timeout_sec=0.1)
            collisions = (
                sum(r.wall_collisions for r in node._fleet.robots),
                sum(sum(r.robot_collisions.values()) for r in node._fleet.robots) // 2,
            )
        finally:
            executor.shutdown()
            for each in (node, *drivers):
                each.destroy_node()
            context.try_shutdown()
    (first, wall0, cpu0), (last_step, wall1, cpu1) = marks["start"], marks["end"]
    return {
        "robots": count,
        "seconds": cpu1 - cpu0,
        "wall": wall1 - wall0,
        "steps": last_step - first,
        "collisions": collisions,
    }


def crossing_figure(path: Path, steps: int = 130) -> Path:
    """The crossing world after `steps` of each robot heading for its goal but for the bump-and-turn rule."""
    fleet = Fleet(load_world(resolve_world_path("fleets/crossing.yaml")))
    for _ in range(steps):
        commands = []
        for robot in fleet.robots:
            error = wrap_angle(math.atan2(robot.goal.y - robot.pose.y, robot.goal.x - robot.pose.x) - robot.pose.theta)
            v, w = bump_and_turn(np.asarray(robot.ranges))
            commands.append((v, w) if v == 0.0 else (0.2 * max(0.0, math.cos(error)), 2.0 * error))
        fleet.step(commands)
    return fleet.render(path, dpi=90)


def irsim_runs(description: dict, python: str | None) -> tuple[dict | None, str]:
    """IR-SIM's runs on the scene, or None and why not."""
    if importlib.util.find_spec("irsim") is not None and python is None:
        python = sys.executable
    if python is None:
        return None, "IR-SIM skipped: ir-sim does not import here and no --irsim-python was given"
    result = subprocess.run(
        [python, str(HERE / "fleet_peer_irsim.py")],
        input=json.dumps(description),
        capture_output=True,
        text=True,
        env=child_environment(),
    )
    if result.returncode != 0:
        return None, f"IR-SIM skipped: {python} failed: {result.stderr.strip().splitlines()[-1:]}"
    return json.loads(result.stdout.strip().splitlines()[-1]), ""  # IR-SIM prints its own lines first


def row(name: str, run_: dict, dt: float, first: dict | None) -> str:
    per_step = run_["seconds"] / run_["steps"]
    per_robot = per_step / run_["robots"]
    growth = "" if first is None else f"{per_robot / (first['seconds'] / first['steps']):9.2f}"
    wall = run_["wall"] / run_["steps"]
    return (
        f"{name:13} {run_['robots']:6d} | {1.0 / per_step:9.0f} {dt / per_step:8.1f}x {per_step * 1e6:9.0f} "
        f"{per_robot * 1e6:9.0f} {growth:>9} | {dt / wall:8.1f}x | {run_['collisions']}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=400, help="steps per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs per figure; the fastest is reported")
    parser.add_argument("--counts", type=int, nargs="+", default=list(COUNTS), help="robot counts")
    parser.add_argument("--irsim-python", help="a Python with ir-sim 2.12 installed (if this one lacks it)")
    parser.add_argument("--no-irsim", action="store_true", help="skip IR-SIM")
    parser.add_argument("--profile", type=int, metavar="N", help="print a cProfile of our run with N robots")
    parser.add_argument("--figure", type=Path, help="only draw docs/fleet.md's picture of fleets/crossing.yaml here")
    parser.add_argument(
        "--ros",
        action="store_true",
        help="also through ROS: the simulator node and a driver node per robot, composed, lockstep",
    )
    parser.add_argument("--ros-only", action="store_true", help="through ROS and the library only (no IR-SIM)")
    parser.add_argument(
        "--ros-lean", action="store_true", help="also through ROS with only /clock, odometry and scan published"
    )
    parser.add_argument(
        "--ros-executor",
        choices=("single", "events"),
        default="single",
        help="the executor of the ROS runs: rclpy's SingleThreadedExecutor (default, what the suite's "
        "nodes spin on) or its experimental EventsExecutor (rclpy.experimental, for comparison)",
    )
    parser.add_argument("--ros-steps", type=int, default=400, help="timed steps per ROS run")
    parser.add_argument("--ros-warmup", type=int, default=40, help="steps before the ROS timing starts")
    args = parser.parse_args()
    if args.figure:
        print(f"wrote {crossing_figure(args.figure)}")
        return
    description = scene(tuple(args.counts), args.steps, args.repeats)
    dt = description["dt"]
    print(
        f"Fleet steps, 8 x 6 m room with 4 boxes, {description['beams']} beams per robot, dt = {dt} s, "
        f"{args.steps} steps, best of {args.repeats}; only the simulator's step is timed"
    )
    print(
        f"{'simulator':13} {'robots':>6} | {'steps/s':>9} {'realtime':>9} {'us/step':>9} {'us/robot':>9} "
        f"{'per robot':>9} | {'realtime':>9} | collisions"
    )
    print(
        f"{'':13} {'':6} | {'(CPU time)':>9} {'':9} {'':9} {'':9} {'vs 1':>9} | {'wall clock':>9} | "
        "ours: wall, robot pairs; IR-SIM: robots stopped"
    )
    ours = [run(description, count) for count in args.counts]
    for result in ours:
        print(row("amr", result, dt, ours[0]))
    if args.ros or args.ros_only:
        library = {result["robots"]: result for result in ours}
        print(
            f"through ROS ({args.ros_executor} executor): {args.ros_steps} steps after {args.ros_warmup}, best of "
            f"{args.repeats}; 'per robot vs 1' "
            "against the library's one robot; last column: the library's share of a ROS step (CPU)"
        )
        for lean in (False, True) if args.ros_lean else (False,):
            for count in args.counts:
                result = min(
                    (
                        ros_run(description, count, args.ros_steps, args.ros_warmup, lean, args.ros_executor)
                        for _ in range(args.repeats)
                    ),
                    key=lambda r: r["seconds"] / r["steps"],
                )
                share = (library[count]["seconds"] / library[count]["steps"]) / (result["seconds"] / result["steps"])
                print(
                    row("amr ROS lean" if lean else "amr ROS", result, dt, library.get(1))
                    + f" | library {100 * share:.0f} %"
                )
    if not args.no_irsim and not args.ros_only:
        peer, why = irsim_runs(description, args.irsim_python)
        if peer is None:
            print(why)
        else:
            for result in peer["runs"]:
                print(row(f"IR-SIM {peer['version']}", result, dt, peer["runs"][0]))
    if args.profile:
        profiler = cProfile.Profile()
        fleet = Fleet(world(description, args.profile))
        profiler.enable()
        for _ in range(args.steps):
            fleet.step([bump_and_turn(np.asarray(robot.ranges)) for robot in fleet.robots])
        profiler.disable()
        print(f"\nProfile, {args.profile} robots, {args.steps} steps (the rule included)")
        pstats.Stats(profiler).sort_stats("tottime").print_stats(18)


if __name__ == "__main__":
    main()
