"""The main job: the maze stack in lockstep, global localization on the seed maze, then IK through the
service; pictures and figures in out/.

The maze run is recorded (out/maze_run, a rosbag2 MCAP bag of /ground_truth, /scan, /map, /tf_static)
and drawn from that bag as an animation, out/maze.gif.

Everything runs as real ROS 2 nodes in one process (a composed bringup): the simulator,
the wall follower and the lifecycle manager, then the maze_localization and maze_navigation stacks
as their bringup files give them, then the IK service. The demo itself only observes topics and calls
services, as any other ROS client would.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import numpy as np
import rclpy
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMessage
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from amr_bringup import demo_figures
from amr_bringup.bag_animation import animate_bag
from amr_bringup.composed import composed_stack
from amr_bringup.lifecycle_manager import LifecycleManager
from amr_bringup.recorder import BackgroundSpin, Recorder
from amr_control.wall_follower_node import WallFollowerNode
from amr_interfaces.msg import LocalizedPose, SimulatorStatus, WallFollowerStatus
from amr_interfaces.srv import ComputeFK, SolveIK
from amr_kinematics.ik_service_node import IKServiceNode
from amr_maps.map_server_node import MapServerNode
from amr_maps.world import load_world, resolve_world_path
from amr_simulation.simulator_node import SimulatorNode
from amr_turtlebot3.odometry_node import OdometryNode
from amr_util.executors import NodeSpinners
from amr_util.geometry import yaw_from_quaternion
from amr_util.share import share_directory
from amr_util.stamps import stamp_seconds

FOLLOWING = "FOLLOW"  # the state in which the distance to the wall is being controlled
PROGRESS_PERIOD = 3.0  # wall-clock seconds between progress lines
CALL_TIMEOUT = 10.0
SIM_TIME = "use_sim_time:=true"
RECORDED_TOPICS = ["/ground_truth", "/scan", "/map", "/tf_static"]
"""What the animation needs (the path, the scans; /map and /tf_static for amr-render-bag)."""


def config_file(package: str, name: str) -> str:
    return str(share_directory(package) / "config" / name)


def params_file_args(path: str, *overrides: str, name: str | None = None) -> list[str]:
    args = ["--ros-args", "--params-file", path]
    for override in overrides:
        args += ["-p", override]
    if name:
        args += ["-r", f"__node:={name}"]
    return args


class Observer(Node):
    """Records what the stack publishes: simulator status and the follower's status."""

    def __init__(self, **kwargs) -> None:
        super().__init__("demo_observer", **kwargs)
        self.lock = threading.Lock()
        self.sim: SimulatorStatus | None = None
        self.follower: list[tuple[float, float, float, bool]] = []  # t, wall distance, target, following
        self.create_subscription(SimulatorStatus, "simulator/status", self._on_sim, 10)
        self.create_subscription(WallFollowerStatus, "wall_follower/status", self._on_follower, 100)

    def _on_sim(self, message: SimulatorStatus) -> None:
        with self.lock:
            self.sim = message

    def _on_follower(self, message: WallFollowerStatus) -> None:
        t = stamp_seconds(message.header.stamp)
        with self.lock:
            self.follower.append((t, message.wall_distance, message.target_wall_distance, message.state == FOLLOWING))


def call(node: Node, service_type, name: str, request):
    """A blocking service call (the executor spins on another thread)."""
    client = node.create_client(service_type, name)
    try:
        if not client.wait_for_service(timeout_sec=CALL_TIMEOUT):
            raise RuntimeError(f"service {name} is not available")
        response = client.call(request, CALL_TIMEOUT)
        if response is None:
            raise RuntimeError(f"service {name} did not answer within {CALL_TIMEOUT} s")
        return response
    finally:
        node.destroy_client(client)


@contextmanager
def spinning(context, nodes: Sequence[Node]) -> Iterator[NodeSpinners]:
    """The nodes spun as amr-bringup spins a composed stack (amr_util.executors: an executor and a thread per node);
    on exit the executors stop first, then the nodes are destroyed (a node destroyed under a spinning executor can
    kill its thread mid-wait)."""
    spinners = NodeSpinners(context)
    for node in nodes:
        spinners.add_node(node)
    try:
        yield spinners
    finally:
        spinners.shutdown(timeout_sec=5.0)
        for node in nodes:
            node.destroy_node()


def run_maze(
    context,
    world: str,
    duration: float,
    *,
    odometry_node: bool = False,
    follower_config: str = "wall_follower_sim.yaml",
    render_path: Path | None = None,
    simulator_overrides: Sequence[str] = (),
    follower_overrides: Sequence[str] = (),
    progress: bool = True,
    record_path: Path | None = None,
) -> tuple[dict, np.ndarray]:
    """The maze stack for `duration` simulated seconds (or to the goal), lockstep unless overridden.

    With odometry_node, the simulator publishes only /odom, as a real TurtleBot3 does, and
    amr_turtlebot3's odometry_node derives the /odometry the follower reads. Returns the run's
    figures and the follower's samples (t, wall distance, target, following). With record_path, a
    recorder writes RECORDED_TOPICS there (each node activates once the recorder listens).
    """
    # one time base: the simulator publishes /clock, every node of the stack runs on it
    simulator = SimulatorNode(
        context=context,
        cli_args=params_file_args(
            config_file("amr_simulation", "simulator.yaml"),
            f"world:={world}",
            SIM_TIME,
            f"publish_odometry:={'false' if odometry_node else 'true'}",
            *([f"render_path:={render_path}"] if render_path else []),
            *simulator_overrides,
        ),
    )
    follower = WallFollowerNode(
        context=context,
        cli_args=params_file_args(config_file("amr_control", follower_config), SIM_TIME, *follower_overrides),
    )
    odometry = [OdometryNode(context=context, cli_args=["--ros-args", "-p", SIM_TIME])] if odometry_node else []
    map_server = MapServerNode(context=context, cli_args=["--ros-args", "-p", f"world:={world}", "-p", SIM_TIME])
    stack = [map_server, follower] + odometry + [simulator]
    recorder = (
        Recorder(
            context=context,
            parameter_overrides=[
                Parameter("path", value=str(record_path)),
                Parameter("topics", value=RECORDED_TOPICS),
                Parameter("use_sim_time", value=True),
            ],
        )
        if record_path
        else None
    )
    recording = BackgroundSpin(recorder) if recorder else None
    # listeners first: the simulator publishes its first observation when it activates
    manager = LifecycleManager(
        before_activate=lambda node: recorder and recorder.wait_until_caught_up(),
        context=context,
        parameter_overrides=[Parameter("node_startup_order", value=[node.get_name() for node in stack])],
    )
    observer = Observer(context=context)
    with spinning(context, stack + [manager, observer]):
        if not all(step.ok for step in manager.startup()):
            raise RuntimeError("the maze stack did not come up (see the log above)")
        started = time.monotonic()
        if progress:
            print(
                f"maze: {world}, lockstep, {' -> '.join(n.get_name() for n in stack)}, "
                f"{duration:.0f} s of simulated time or until the goal"
            )
        status = wait_for_run(observer, duration, started, progress)
        elapsed = time.monotonic() - started
        rendered = call(observer, Trigger, "simulator/render", Trigger.Request()) if render_path else None
        manager.shutdown()
    if recording:
        recording.stop()  # finishes the bag
    with observer.lock:
        samples = np.array(observer.follower) if observer.follower else np.zeros((0, 4))
    following = samples[(samples[:, 3] == 1) & np.isfinite(samples[:, 1])]
    target = float(samples[0, 2]) if len(samples) else math.nan
    summary = {
        "world": world,
        "odometry_node": odometry_node,
        "simulated_time_s": round(status.sim_time, 3),
        "wall_time_s": round(elapsed, 3),
        "speed_up": round(status.sim_time / elapsed, 2),
        "distance_m": round(status.distance_travelled, 3),
        "mean_speed_m_s": round(status.distance_travelled / max(status.sim_time, 1e-9), 4),
        "collisions": int(status.collisions),
        "goal_reached": bool(status.goal_reached),
        "target_wall_distance_m": target,
        "mean_abs_wall_error_following_m": round(float(np.mean(np.abs(following[:, 1] - target))), 4)
        if len(following)
        else None,
    }
    if rendered is not None:
        summary["render"] = rendered.message if rendered.success else f"failed: {rendered.message}"
    return summary, samples


def wait_for_run(observer: Observer, duration: float, started: float, progress: bool) -> SimulatorStatus:
    last_print = 0.0
    deadline_without_progress = time.monotonic() + 15.0
    last_time = -1.0
    while True:
        time.sleep(0.05)
        with observer.lock:
            status = observer.sim
            state = len(observer.follower)
        if status is None or status.sim_time <= last_time:
            if time.monotonic() > deadline_without_progress:
                raise RuntimeError("the simulation stopped advancing (no /simulator/status for 15 s)")
            continue
        last_time, deadline_without_progress = status.sim_time, time.monotonic() + 15.0
        now = time.monotonic()
        done = status.sim_time >= duration or status.goal_reached
        if progress and (now - last_print >= PROGRESS_PERIOD or done):
            last_print = now
            print(
                f"  t = {status.sim_time:6.1f} s sim | {status.distance_travelled:6.2f} m | "
                f"collisions {status.collisions} | {status.sim_time / (now - started):5.1f}x real time | "
                f"{state} commands" + (" | goal reached" if status.goal_reached else ""),
                flush=True,
            )
        if done:
            return status


def planar(pose) -> tuple[float, float, float]:
    return pose.position.x, pose.position.y, yaw_from_quaternion(pose.orientation)


class LocalizationObserver(Observer):
    """Also records the filter's /pose and /particle_cloud and the simulator's ground truth, by stamp."""

    def __init__(self, **kwargs) -> None:
        super().__init__(**kwargs)
        self.poses: list[tuple[float, tuple, bool]] = []
        self.clouds: list[tuple[float, np.ndarray]] = []
        self.truth: dict[float, tuple] = {}
        self.create_subscription(LocalizedPose, "pose", self._on_pose, 100)
        self.create_subscription(PoseArray, "particle_cloud", self._on_cloud, 10)
        self.create_subscription(Odometry, "ground_truth", self._on_truth, 100)

    def _on_pose(self, message: LocalizedPose) -> None:
        with self.lock:
            self.poses.append((stamp_seconds(message.header.stamp), planar(message.pose.pose), message.localized))

    def _on_cloud(self, message: PoseArray) -> None:
        particles = np.array([planar(p) for p in message.poses])
        with self.lock:
            self.clouds.append((stamp_seconds(message.header.stamp), particles))

    def _on_truth(self, message: Odometry) -> None:
        with self.lock:
            self.truth[stamp_seconds(message.header.stamp)] = planar(message.pose.pose)


NAVIGATION_WORLD = "pillar_goal.yaml"  # a goal beside a free-standing pillar: a wall follower never gets there
NAVIGATION_DURATION = 120.0  # s of simulated time at most
LOCALIZATION_CLOUD_PERIOD = 0.25  # s of simulated time between the particle clouds the demo records


def run_localization(context, out: Path, world: str, duration: float) -> dict:
    """The maze_localization stack on `world` (map server, simulator, wall follower, particle filter: the filter
    takes the map server's /map): global localization from an unknown start while the wall follower explores."""
    observer = LocalizationObserver(context=context)
    with composed_stack(
        context,
        "maze_localization",
        arguments={"world": world},
        parameters={"particle_filter.particle_cloud_period": str(LOCALIZATION_CLOUD_PERIOD)},
        extra_nodes=[observer],
    ) as (_, manager, _):
        if not all(step.ok for step in manager.startup()):
            raise RuntimeError("the localization stack did not come up (see the log above)")
        started = time.monotonic()
        print(
            f"localization: {world}, maze_localization (map server, particle filter, wall follower, simulator), "
            f"{duration:.0f} s simulated"
        )
        status = wait_for_run(observer, duration, started, progress=True)
        elapsed = time.monotonic() - started
    with observer.lock:
        poses, clouds, truth = list(observer.poses), list(observer.clouds), dict(observer.truth)
    rows = [(t, pose, localized, truth[t]) for t, pose, localized in poses if t in truth]
    if not rows or not clouds:
        raise RuntimeError(
            f"localization: the particle filter answered {len(rows)} scans with a /pose and published "
            f"{len(clouds)} particle clouds in {duration:.0f} s simulated: nothing to draw (see the log above)"
        )
    times = np.array([r[0] for r in rows])
    position_error = np.array([math.hypot(r[1][0] - r[3][0], r[1][1] - r[3][1]) for r in rows])
    heading_error = np.degrees([abs(math.remainder(r[1][2] - r[3][2], 2 * math.pi)) for r in rows])
    localized = np.array([r[2] for r in rows], dtype=bool)
    first = int(np.argmax(localized)) if localized.any() else None
    demo_figures.localization_error_figure(
        out / "localization_error.png", times, position_error, heading_error, localized
    )
    t_first = times[first] if first is not None else times[-1]
    wanted = [
        ("spread: global localization", clouds[0][0]),
        ("clustering", 0.3 * t_first),
        ("localized" if first is not None else "not localized", t_first),
    ]
    snapshots = []
    for title, when in wanted:
        t, particles = min(clouds, key=lambda cloud: abs(cloud[0] - when))
        index = int(np.argmin(np.abs(times - t)))
        estimate = rows[index][1] if localized[index] else None
        snapshots.append((f"{title} (t = {t:.2f} s)", particles, truth.get(t, rows[index][3]), estimate))
    polygons = load_world(resolve_world_path(world)).polygons
    demo_figures.localization_figure(out / "localization.png", polygons, snapshots)
    after = localized & (times >= t_first)
    summary = {
        "world": world,
        "simulated_time_s": round(status.sim_time, 3),
        "wall_time_s": round(elapsed, 3),
        "collisions": int(status.collisions),
        "localized": first is not None,
    }
    if first is not None:
        summary.update(
            {
                "first_localized_s": round(float(t_first), 3),
                "error_at_first_localized_cm": round(100 * float(position_error[first]), 2),
                "heading_error_at_first_localized_deg": round(float(heading_error[first]), 2),
                "rms_error_while_localized_cm": round(100 * float(np.sqrt(np.mean(position_error[after] ** 2))), 2),
                "rms_heading_error_while_localized_deg": round(float(np.sqrt(np.mean(heading_error[after] ** 2))), 2),
                "share_of_time_localized_after_first": round(float(after.sum() / max((times >= t_first).sum(), 1)), 3),
            }
        )
    return summary


class NavigationObserver(LocalizationObserver):
    """Also records every /path the navigator publishes (one per plan handed to the path follower)."""

    def __init__(self, **kwargs) -> None:
        super().__init__(**kwargs)
        self.paths: list[tuple[float, np.ndarray]] = []
        self.create_subscription(PathMessage, "path", self._on_path, 10)

    def _on_path(self, message: PathMessage) -> None:
        points = np.array([[p.pose.position.x, p.pose.position.y] for p in message.poses])
        with self.lock:
            self.paths.append((stamp_seconds(message.header.stamp), points))


def run_navigation(context, out: Path, world: str, duration: float) -> dict:
    """The maze_navigation stack on `world`: explore until localized, plan, go; the navigator
    decides who drives, the world's goal is its goal."""
    observer = NavigationObserver(context=context)
    with composed_stack(context, "maze_navigation", arguments={"world": world}, extra_nodes=[observer]) as (
        _,
        manager,
        _,
    ):
        if not all(step.ok for step in manager.startup()):
            raise RuntimeError("the navigation stack did not come up (see the log above)")
        started = time.monotonic()
        print(f"navigation: {world}, maze_navigation (explore, localize, plan, go); {duration:.0f} s simulated at most")
        status = wait_for_run(observer, duration, started, progress=True)
        elapsed = time.monotonic() - started
    with observer.lock:
        poses, truth, paths = list(observer.poses), dict(observer.truth), list(observer.paths)
    localized = [t for t, _, flag in poses if flag]
    first = localized[0] if localized else None
    stamps = sorted(truth)
    trajectory = np.array([truth[t][:2] for t in stamps])
    localized_at = {t: flag for t, _, flag in poses}
    explored = np.array([not localized_at.get(t, False) for t in stamps])  # the wall follower's steps
    loaded = load_world(resolve_world_path(world))
    demo_figures.navigation_figure(
        out / "navigation.png",
        loaded.polygons,
        loaded.goal,
        trajectory,
        explored,
        [points for _, points in paths],
        title=(f"{world}: localized at t = {first:.1f} s, " if first is not None else f"{world}: not localized, ")
        + (
            f"goal at t = {status.sim_time:.1f} s"
            if status.goal_reached
            else f"goal not reached in {status.sim_time:.0f} s"
        ),
    )
    return {
        "world": world,
        "simulated_time_s": round(status.sim_time, 3),
        "wall_time_s": round(elapsed, 3),
        "collisions": int(status.collisions),
        "goal_reached": bool(status.goal_reached),
        "first_localized_s": None if first is None else round(first, 3),
        "plans": len(paths),
        "distance_m": round(float(status.distance_travelled), 3),
    }


def joint_origins(node: Node, chain: str, positions) -> np.ndarray:
    response = call(node, ComputeFK, "compute_fk", ComputeFK.Request(chain=chain, positions=list(positions)))
    if not response.success:
        raise RuntimeError(f"compute_fk {chain}: {response.message}")
    return np.array([[p.x, p.y, p.z] for p in response.joint_origins])


def solve(node: Node, chain: str, x: float, y: float, z: float = 0.0, **fields) -> SolveIK.Response:
    request = SolveIK.Request(chain=chain, **fields)
    request.target.position.x, request.target.position.y, request.target.position.z = x, y, z
    return call(node, SolveIK, "solve_ik", request)


def iteration_history(node: Node, chain: str, target, seed, iterations: int, solver: str) -> list[np.ndarray]:
    """The arm after 0, 1, ... iterations: the same deterministic solve cut short by max_iterations."""
    history = [joint_origins(node, chain, seed)]
    for k in range(1, iterations + 1):
        response = solve(node, chain, *target, seed=list(seed), solver=solver, max_iterations=k)
        history.append(joint_origins(node, chain, response.positions))
    return history


def run_ik(context, out: Path) -> dict:
    ik = IKServiceNode(context=context, cli_args=params_file_args(config_file("amr_kinematics", "ik_chains.yaml")))
    manager = LifecycleManager(
        context=context,
        cli_args=["--ros-args", "-r", "__node:=ik_manager"],
        parameter_overrides=[Parameter("node_startup_order", value=["ik_service"])],
    )
    client = Node("demo_ik_client", context=context)
    with spinning(context, [ik, manager, client]):
        if not all(step.ok for step in manager.startup()):
            raise RuntimeError("the IK service did not come up (see the log above)")
        results = {}

        # seed 004: the 5-DOF arm, DLS with lambda^2 = 50 (cm^2), tool pointing down
        start = [math.radians(a) for a in (0.0, 60.0, -40.0, -50.0, -60.0)]
        target = (0.053, 0.0478, 0.0)
        arm5 = solve(client, "arm5", *target, seed=start, solver="dls")
        history = iteration_history(client, "arm5", target, start, arm5.iterations, "dls")
        demo_figures.arm_iterations_figure(
            out / "ik_dls.png",
            history,
            target,
            f"DLS, 5-DOF arm: {arm5.iterations} iterations, error {arm5.position_error * 100:.4f} cm",
        )
        results["arm5_dls"] = summary_of(arm5, scale=100.0, unit="cm")

        # ULL report: the 5-joint planar robot (rotation, prismatic, rotation, rotation, prismatic) by CCD
        home = [0.0, 0.05, 0.0, 0.0, 0.05]
        ccd_target = (0.10, 0.10, 0.0)
        ull5 = solve(client, "ull5", *ccd_target, seed=home, solver="ccd")
        history = iteration_history(client, "ull5", ccd_target, home, ull5.iterations, "ccd")
        demo_figures.planar_iterations_figure(
            out / "ik_ccd.png", history, ccd_target, f"CCD, ULL 5-joint planar robot: {ull5.iterations} iterations"
        )
        results["ull5_ccd"] = summary_of(ull5, scale=100.0, unit="cm")

        # seed 001: the 2R arm (l1 = l2 = 2) along a straight line, each solve seeded with the last
        waypoints = np.linspace((3.0, -1.0), (-1.0, 3.0), 41)
        seed, joints, origins, successes = [0.0, 0.5], [], [], 0
        for x, y in waypoints:
            response = solve(client, "rr2", x, y, seed=seed, solver="analytic")
            successes += response.success
            seed = list(response.positions)
            joints.append(seed)
            origins.append(joint_origins(client, "rr2", seed))
        joints = np.array(joints)
        largest_step = float(np.max(np.abs(np.diff(joints, axis=0)))) if len(joints) > 1 else 0.0
        demo_figures.path_tracking_figure(
            out / "ik_2r_path.png",
            waypoints,
            origins,
            joints,
            f"2R closed form along a line: largest joint step {math.degrees(largest_step):.1f} deg",
        )
        results["rr2_path"] = {
            "waypoints": len(waypoints),
            "successes": successes,
            "largest_joint_step_deg": round(math.degrees(largest_step), 3),
        }

        # the industrial arms: position-only and full pose to a reachable target
        for chain in ("ur5", "panda"):
            response = solve(client, chain, 0.3, 0.2, 0.4)
            results[f"{chain}_position"] = summary_of(response)
        manager.shutdown()
    return results


def summary_of(response: SolveIK.Response, scale: float = 1.0, unit: str = "m") -> dict:
    return {
        "success": bool(response.success),
        "iterations": int(response.iterations),
        f"position_error_{unit}": round(response.position_error * scale, 6),
        "positions": [round(q, 6) for q in response.positions],
        "message": response.message,
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=180.0, help="simulated seconds (default 180)")
    parser.add_argument("--world", default="inner_maze.yaml", help="a world in share/amr_maps/config/worlds")
    parser.add_argument(
        "--localization-duration",
        type=float,
        default=40.0,
        help="simulated seconds of the localization run (default 40)",
    )
    parser.add_argument("--out", type=Path, default=Path("out"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    out = args.out.resolve()

    context = rclpy.Context()
    rclpy.init(context=context)
    started = time.monotonic()
    try:
        bag = out / "maze_run"
        shutil.rmtree(bag, ignore_errors=True)  # a recording never overwrites: the demo replaces its own
        maze, samples = run_maze(context, args.world, args.duration, render_path=out / "maze.png", record_path=bag)
        gif_started = time.monotonic()
        world = load_world(resolve_world_path(args.world))
        animate_bag(bag, out / "maze.gif", world, frames=180)
        maze["animation"] = {"gif": "maze.gif", "bag": "maze_run", "seconds": round(time.monotonic() - gif_started, 2)}
        demo_figures.wall_distance_figure(
            out / "wall_distance.png", samples[:, 0], samples[:, 1], maze["target_wall_distance_m"], samples[:, 3] == 0
        )
        summary = {"maze": maze}
        print(f"maze done: {json.dumps(summary['maze'])}")
        summary["localization"] = run_localization(context, out, args.world, args.localization_duration)
        print(f"localization done: {json.dumps(summary['localization'])}")
        summary["navigation"] = run_navigation(context, out, NAVIGATION_WORLD, NAVIGATION_DURATION)
        print(f"navigation done: {json.dumps(summary['navigation'])}")
        summary["ik"] = run_ik(context, out)
    finally:
        context.try_shutdown()
    summary["total_wall_time_s"] = round(time.monotonic() - started, 2)
    summary["figures"] = sorted(p.name for p in out.glob("*.png"))
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(json.dumps(summary, indent=2))
    print(f"wrote {out / 'summary.json'} and {len(summary['figures'])} figures")


if __name__ == "__main__":
    main()
