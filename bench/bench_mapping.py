"""maze_mapping on generated maze families: explore an unknown maze with slam + explorer + planner +
navigator + path follower, through ROS (the composed stack, lockstep on simulated time) or, with --library, the same
objects in one loop without ROS (faster: the model's figures without the transport), and judge the saved map
against the world.

The library loop does what the stack's nodes do, in process, one simulator step per command: GraphSlam.add on
every scan (config/slam.yaml with config/bringup/maze_mapping.yaml's slam parameters over it), the map handed to a
new Planner (config/planner.yaml) and to the Explorer (config/explorer.yaml) at most every 1 s of scan time once it
changed (slam's map_publish_period), the explorer
deciding as the explorer node does (at once with no goal, after a new map at most every decision_period s, on the
navigator's REACHED / NO_PATH of its goal), the NavigationLoop (navigator, planner, path follower of
config/path_follower_sim.yaml) driving to the goal.

Each run: a world of amr_maps.maze_families (family, seed), LiDAR noise, encoder noise and slip, the stack
`maze_mapping world:=<it> save_to:=<dir>/<run>` until the explorer says `done` (it saves the map then) or the
simulated-time budget runs out. Printed per run:

- done: simulated s when the explorer said done (`-` if it never did: then the map is saved at the budget's end)
- known: share of the reachable free cells (the world rasterized at the map's resolution, free cells 8-connected
  to the start) that the saved map knows (free or occupied)
- precise: share of the saved map's occupied cells within one cell of a true wall
- walls: share of the true wall cells bordering reachable space that the saved map marks occupied within one cell
- with --library: loop closures in the final graph, the pose error at the end, and the final graph's nodes
  against the true poses where they were added (mean / max, m: the drift the map is drawn with)
- collisions (the simulator's wall contacts), goals the explorer gave up (failed or timed out; through ROS: the
  Frontiers message's count, frontiers given up at a reached goal included), wall-clock s
- with --navigate, then: `maze_navigation world:=<it> map:=<run>.yaml` as the evaluation runs it (amr_evaluation
  navigation episode with option map, in the library: the particle filter and the planner on the saved map, from
  no pose; the simulator on the world, the same noise, the world's goal): reached or not, simulated s, first
  localized s, the largest localization error while localized (against the truth), collisions

The saved map is in slam's map frame, the odom frame of the first scan: the simulator's odometry starts at the
world's start pose, so it is the world's frame (what `maze_navigation world:=<world> map:=<run>.yaml` takes as
it is). Prints; asserts nothing.

    .venv/bin/python bench/bench_mapping.py [--families perfect loops rotated pillars open_room] [--seeds 0 1 2]
        [--lidar-noise 0.01 0.03] [--encoder-noise 0.02] [--slip 0.05] [--budget 900] [--resolution 0.025] [--out DIR]
        [--library] [--verbose] [--slam KEY=VALUE ...]

--slam overrides config/slam.yaml's slam parameters (e.g. `--slam local_window=20`: a SlamConfig experiment
without editing the shipped file).
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from scipy import ndimage

from amr_maps.map_io import load_map
from amr_maps.maze_families import generate
from amr_maps.rasterize import rasterize_world
from amr_maps.world import world_from_dict
from amr_util.parameter_file import node_parameters

ROOT = Path(__file__).resolve().parents[1]

FAMILIES = ("perfect", "loops", "rotated", "pillars", "open_room")


def judge(saved, world) -> dict:
    """known / precise / walls shares of the saved map (world frame) against the world rasterized alike."""
    truth = rasterize_world(world, resolution=saved.resolution)
    walls = truth.occupied()
    free = ~walls
    labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
    row, col = truth.world_to_cell(world.start.x, world.start.y)
    reachable = labels == labels[int(row), int(col)]
    # the saved map's cells looked up at the truth's cell centres
    rows, cols = np.mgrid[0 : truth.height, 0 : truth.width]
    x, y = truth.cell_to_world(rows, cols)
    srow, scol = saved.world_to_cell(x, y)
    inside = (srow >= 0) & (srow < saved.height) & (scol >= 0) & (scol < saved.width)
    values = np.full(truth.data.shape, -1, dtype=np.int16)
    values[inside] = saved.data[srow[inside], scol[inside]]
    known = values >= 0
    marked = saved.occupied()
    near_wall = ndimage.binary_dilation(walls, structure=np.ones((3, 3)))
    # every occupied cell of the saved map, at its centre, against the truth
    mrow, mcol = np.nonzero(marked)
    mx, my = saved.cell_to_world(mrow, mcol)
    trow, tcol = truth.world_to_cell(mx, my)
    tin = (trow >= 0) & (trow < truth.height) & (tcol >= 0) & (tcol < truth.width)
    precise = np.zeros(len(mrow), dtype=bool)
    precise[tin] = near_wall[trow[tin], tcol[tin]]
    bordering = walls & ndimage.binary_dilation(reachable, structure=np.ones((3, 3)))
    occupied_here = np.zeros(truth.data.shape, dtype=bool)
    occupied_here[inside] = marked[srow[inside], scol[inside]]
    seen_wall = ndimage.binary_dilation(occupied_here, structure=np.ones((3, 3)))
    return {
        "known": float(known[reachable].mean()),
        "precise": float(precise.mean()) if len(precise) else 0.0,
        "walls": float(seen_wall[bordering].mean()) if bordering.any() else 0.0,
    }


def run(
    context,
    family: str,
    seed: int,
    lidar_noise: float,
    encoder_noise: float,
    slip: float,
    budget: float,
    out: Path,
    resolution: float | None = None,
    slam_overrides: dict | None = None,
) -> dict:
    """One maze_mapping run; the figures of the module docstring."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    from amr_bringup.composed import composed_stack
    from amr_interfaces.msg import Frontiers, SimulatorStatus
    from amr_interfaces.srv import SaveMap
    from amr_util.qos import reliable

    data = generate(family, seed)
    world = world_from_dict(data, source=f"{family} seed {seed}")
    name = f"{family}_{seed}"
    world_path = out / f"{name}.world.yaml"
    world_path.write_text(yaml.safe_dump(data), encoding="utf-8")
    save_to = out / name
    for suffix in (".yaml", ".pgm", ".poses.csv"):
        Path(f"{save_to}{suffix}").unlink(missing_ok=True)
    parameters = {
        "simulator.lidar.noise_std": str(lidar_noise),
        "simulator.encoders.noise": str(encoder_noise),
        "simulator.encoders.slip": str(slip),
        "simulator.seed": str(seed),
    }
    if resolution is not None:
        parameters["slam.resolution"] = str(resolution)
    for key, value in (slam_overrides or {}).items():
        parameters[f"slam.{key}"] = str(value)
    started = time.monotonic()
    done_at, state, statuses, blacklisted = None, "", [], 0
    with composed_stack(
        context, "maze_mapping", arguments={"world": str(world_path), "save_to": str(save_to)}, parameters=parameters
    ) as (_, manager, _):
        if not all(step.ok for step in manager.startup()):
            return {"name": name, "error": "the stack did not come up"}
        probe = Node("mapping_bench", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(probe)
        frontiers: list[Frontiers] = []
        probe.create_subscription(Frontiers, "/explorer/frontiers", frontiers.append, reliable(10))
        probe.create_subscription(SimulatorStatus, "/simulator/status", statuses.append, reliable(10))
        try:
            while True:
                executor.spin_once(timeout_sec=0.05)
                sim_time = statuses[-1].sim_time if statuses else 0.0
                if frontiers:
                    state = frontiers[-1].state
                    blacklisted = int(frontiers[-1].blacklisted)
                if state == "done" and done_at is None:
                    done_at = sim_time
                if done_at is not None and Path(f"{save_to}.yaml").exists():
                    break
                if sim_time > budget or time.monotonic() - started > 20 * budget:
                    break
            if not Path(f"{save_to}.yaml").exists():  # not done: the map as it is at the budget's end
                client = probe.create_client(SaveMap, "/slam/save_map")
                if client.wait_for_service(timeout_sec=10.0):
                    future = client.call_async(SaveMap.Request(path=str(save_to)))
                    deadline = time.monotonic() + 30.0
                    while not future.done() and time.monotonic() < deadline:
                        executor.spin_once(timeout_sec=0.05)
        finally:
            executor.remove_node(probe)
            probe.destroy_node()
            executor.shutdown()
    wall = time.monotonic() - started
    last = statuses[-1] if statuses else None
    result = {
        "name": name,
        "done": done_at,
        "sim_time": last.sim_time if last else math.nan,
        "collisions": int(last.wall_collisions) if last else -1,
        "wall": wall,
        "state": state,
        "given_up": blacklisted,
    }
    if Path(f"{save_to}.yaml").exists():
        result.update(judge(load_map(f"{save_to}.yaml"), world))
    return result


def recorded_inputs(directory: Path, runs: list[str] | None = None) -> list[Path]:
    """The <run>.inputs.npz files `--record` saved in directory (sorted), only the runs named if any are."""
    paths = sorted(Path(directory).glob("*.inputs.npz"))
    return [p for p in paths if p.name.split(".")[0] in runs] if runs else paths


def shipped(node: str, file: str) -> dict:
    """A node's parameters from config/<file> of this tree."""
    return node_parameters(ROOT / "config" / file, node)


def stack_parameters(node: str, stack: str = "maze_mapping") -> dict:
    """The parameters config/bringup/<stack>.yaml sets on a node over its files (use_sim_time aside)."""
    data = yaml.safe_load((ROOT / "config" / "bringup" / f"{stack}.yaml").read_text(encoding="utf-8"))
    for entry in data.get("nodes", []):
        if entry.get("name") == node:
            return {k: v for k, v in (entry.get("parameters") or {}).items() if k != "use_sim_time"}
    return {}


def run_library(
    family: str,
    seed: int,
    lidar_noise: float,
    encoder_noise: float,
    slip: float,
    budget: float,
    out: Path,
    resolution: float | None = None,
    verbose: bool = False,
    slam_overrides: dict | None = None,
    record: bool = False,
) -> dict:
    """One exploration with the stack's objects in one loop, no ROS (module docstring); the figures of run().
    record: every scan's stamp, odometry, ranges and true pose saved as <out>/<run>.inputs.npz (what
    bench/bench_slam_replay.py feeds GraphSlam again, without the explorer's closed loop)."""
    from amr_control.path_follower import PathFollower
    from amr_control.path_follower_config import PathFollowerConfig
    from amr_control.wall_follower import WallFollower
    from amr_control.wall_follower_config import WallFollowerConfig
    from amr_mapping.explorer import DONE, Explorer
    from amr_mapping.explorer_node import config_of as explorer_config_of
    from amr_mapping.slam import GraphSlam
    from amr_mapping.slam_node import config_of as slam_config_of
    from amr_navigation.loop import NavigationLoop
    from amr_navigation.navigator import Mode
    from amr_planning.planner import Planner, PlannerConfig
    from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
    from amr_simulation.simulator import Simulator
    from amr_util.scan import scan_of

    data = generate(family, seed)
    world = world_from_dict(data, source=f"{family} seed {seed}")
    name = f"{family}_{seed}"
    (out / f"{name}.world.yaml").write_text(yaml.safe_dump(data), encoding="utf-8")
    started = time.monotonic()
    simulator = shipped("simulator", "simulator.yaml")
    sim = Simulator(
        world,
        SimulationConfig(
            dt=simulator["dt"],
            seed=seed,
            lidar=LidarConfig(beams=simulator["lidar"]["beams"], noise_std=lidar_noise),
            encoders=EncoderConfig(noise=encoder_noise, slip=slip),
            stop_at_goal=False,  # as maze_mapping's simulator: the world's goal is nobody's goal here
        ),
    )
    slam_params = {**shipped("slam", "slam.yaml"), **stack_parameters("slam")}
    if resolution is not None:
        slam_params["resolution"] = resolution
    slam_params.update(slam_overrides or {})
    slam = GraphSlam(slam_config_of(slam_params))
    map_period = float(slam_params.get("map_publish_period", 1.0))
    explorer_params = shipped("explorer", "explorer.yaml")
    explorer = Explorer(explorer_config_of(explorer_params))
    decision_period = float(explorer_params.get("decision_period", 1.0))
    planner_config = PlannerConfig.from_params({**shipped("planner", "planner.yaml"), "world": ""})
    navigator = shipped("navigator", "navigator.yaml")
    loop = None
    wall = WallFollowerConfig.from_params(shipped("wall_follower", "wall_follower_sim.yaml"))
    follower = PathFollowerConfig.from_params(shipped("path_follower", "path_follower_sim.yaml"))
    grid, map_new, map_dirty, map_at, last_decision, done_at, state = None, False, False, -math.inf, -math.inf, None, ""
    log = []
    failures = 0
    nodes = []  # (t, true x, y, theta, odometry x, y, theta, slam x, y, theta when added)
    inputs = []  # record: (stamp ns, odometry x, y, theta, true x, y, theta), ranges

    def decide(now: float) -> None:
        nonlocal map_new, last_decision, state
        step = explorer.update(grid, slam.pose, now)
        map_new, last_decision, state = False, now, step.state
        for event in explorer.take_events():
            log.append(f"{now:7.1f} explorer: {event}")
        if step.new_goal and step.goal is not None and loop is not None:
            loop.set_goal(step.goal)
        if step.state == DONE:
            log.append(f"{now:7.1f} explorer done: {step.reason}")

    while sim.time <= budget:
        now = sim.time
        scan = scan_of(sim)
        update = slam.add(int(round(now * 1e9)), tuple(sim.odom_pose), scan)
        if record:
            inputs.append(
                ((int(round(now * 1e9)), *sim.odom_pose, sim.pose.x, sim.pose.y, sim.pose.theta), scan.ranges)
            )
        for event in update.events:
            log.append(f"{now:7.1f} slam: {event}")
        for closure in update.loop_closures:
            log.append(f"{now:7.1f} slam: closure {closure.anchor} -> {closure.node} score {closure.score:.2f}")
        if update.node_added:
            truth = sim.pose
            nodes.append((now, truth.x, truth.y, truth.theta, *sim.odom_pose, *update.pose))
        map_dirty = map_dirty or update.map_changed
        if map_dirty and now - map_at >= map_period:
            grid, map_new, map_dirty, map_at = slam.occupancy_grid(), True, False, now
            planner = Planner(grid, planner_config)
            if loop is None:
                loop = NavigationLoop(
                    planner,
                    WallFollower(wall),
                    PathFollower(follower),
                    None,
                    replan_distance=float(navigator["replan_distance"]),
                )
            else:
                loop.planner = planner
        if explorer.goal is None and state != DONE:
            decide(now)
        elif map_new and now - last_decision >= decision_period:
            decide(now)
        elif explorer.goal is not None and now - explorer.goal_since > explorer.config.goal_timeout:
            decide(now)
        if state == DONE:
            done_at = now
            break
        command = None
        for _ in range(3):  # a goal reached or refused: the explorer's next goal answers the same observation
            if loop is None:
                break
            command = loop.step(slam.pose, True, scan, *sim.odom_twist, now)
            if verbose:
                log.extend(f"{now:7.1f} navigator: {event}" for event in command.events)
            goal = explorer.goal
            if goal is None or loop.goal is None or math.hypot(loop.goal[0] - goal[0], loop.goal[1] - goal[1]) > 0.05:
                break
            if command.mode is Mode.REACHED:
                explorer.reached()
            elif command.mode is Mode.NO_PATH:
                explorer.failed(f"the navigator: {' '.join(command.events)}")
                if verbose:  # the map the planner refused to plan on, for a look
                    failures += 1
                    np.savez(
                        out / f"{name}.no_path{failures}.npz",
                        data=grid.data,
                        resolution=grid.resolution,
                        origin=np.array(grid.origin),
                        pose=np.array(slam.pose),
                        goal=np.array(goal),
                    )
                    log.append(f"{now:7.1f} map saved as {name}.no_path{failures}, pose {slam.pose}")
            else:
                break
            decide(now)
            if state == DONE:
                break
        if state == DONE:
            done_at = now
            break
        if verbose and sim.steps % 100 == 0:
            truth, (x, y, theta) = sim.pose, slam.pose
            log.append(
                f"{now:7.1f} at ({truth.x:.2f}, {truth.y:.2f}), error {math.hypot(x - truth.x, y - truth.y):.3f} m "
                f"{math.degrees(abs(math.remainder(theta - truth.theta, math.tau))):.1f} deg"
            )
        v, w = (command.v, command.w) if command is not None else (0.0, 0.0)
        sim.step(v, w)
    slam.optimize()
    save_to = out / name
    slam.save(str(save_to))
    truth = sim.pose
    x, y, theta = slam.pose
    result = {
        "name": name,
        "done": done_at,
        "sim_time": sim.time,
        "collisions": int(sim.collisions),
        "wall": time.monotonic() - started,
        "state": state,
        "given_up": len(explorer.blacklist),
        "closures": int(slam.graph()[2].sum()),
        "pose_error": math.hypot(x - truth.x, y - truth.y),
    }
    if nodes:  # the final graph's nodes against the true poses where they were added
        poses = slam.graph()[0][: len(nodes)]
        true_xy = np.array(nodes)[:, 1:3]
        errors = np.hypot(poses[:, 0] - true_xy[:, 0], poses[:, 1] - true_xy[:, 1])
        result["node_error"] = (float(errors.mean()), float(errors.max()))
    (out / f"{name}.log").write_text("\n".join(log) + "\n", encoding="utf-8")
    if record and inputs:
        np.savez_compressed(
            out / f"{name}.inputs.npz",
            poses=np.array([row for row, _ in inputs], dtype=float),
            ranges=np.array([ranges for _, ranges in inputs], dtype=float),
            scan=np.array([scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max]),
            lidar_noise=lidar_noise,
        )
    if verbose:
        print("\n".join(log))
        np.savez(out / f"{name}.nodes.npz", nodes=np.array(nodes), poses=slam.graph()[0])
    result.update(judge(load_map(f"{save_to}.yaml"), world))
    return result


def navigate(family: str, seed: int, noise: float, args, saved: Path) -> str:
    """`maze_navigation world:=<the run's world> map:=<saved>` as amr_evaluation's navigation episode runs it (the
    library loop: the same navigator, planner, path follower and particle filter the stack's nodes call), the
    filter from no pose on the saved map, the simulator on the world with the run's noise: one line of figures."""
    from amr_evaluation import configs
    from amr_evaluation.episode import EpisodeSpec, run_episode

    label, parameters = configs.resolve("navigation", "default")
    record = run_episode(
        EpisodeSpec(
            "navigation",
            label,
            parameters,
            {"family": family, "seed": seed},
            None,
            seed=seed,
            lidar_noise=noise,
            encoder_noise=args.encoder_noise,
            slip=args.slip,
            duration=args.navigation_budget,
            options={"map": str(saved)},
        )
    )
    if record["error"]:
        return f"navigation on the saved map: {record['error']}"
    localized = record["time_to_localized"]
    error = record["localization_error_max"]
    reached = "reached" if record["goal_reached"] else "NOT reached"
    return (
        f"navigation on the saved map: {reached} at {record['time']:.1f} s"
        f" ({record['reason']}), localized at {'-' if localized is None else f'{localized:.1f} s'}, largest error"
        f" while localized {'-' if error is None else f'{100 * error:.1f} cm'}, collisions {record['collisions']}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--families", nargs="*", default=list(FAMILIES))
    parser.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2])
    parser.add_argument(
        "--lidar-noise",
        nargs=2,
        type=float,
        default=[0.01, 0.03],
        help="LiDAR noise range: run k of a family takes the k-th step of it",
    )
    parser.add_argument("--encoder-noise", type=float, default=0.02)
    parser.add_argument("--slip", type=float, default=0.05)
    parser.add_argument("--budget", type=float, default=900.0, help="s simulated")
    parser.add_argument("--navigation-budget", type=float, default=300.0, help="--navigate: s simulated")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--resolution", type=float, default=None, help="slam's cells (m); default slam.yaml's")
    parser.add_argument("--library", action="store_true", help="the objects in one loop, no ROS (faster)")
    parser.add_argument("--verbose", action="store_true", help="library: print each run's explorer and slam events")
    parser.add_argument("--slam", nargs="*", default=[], metavar="KEY=VALUE", help="slam parameters over slam.yaml's")
    parser.add_argument("--record", action="store_true", help="library: save each run's inputs (bench_slam_replay.py)")
    parser.add_argument(
        "--navigate", action="store_true", help="then navigate on each saved map to the world's goal (library episode)"
    )
    args = parser.parse_args()
    slam_overrides = {}
    for item in args.slam:
        key, _, value = item.partition("=")
        if not value:
            parser.error(f"--slam {item!r}: KEY=VALUE expected")
        slam_overrides[key] = yaml.safe_load(value)
    out = args.out or Path(tempfile.mkdtemp(prefix="bench_mapping_"))
    out.mkdir(parents=True, exist_ok=True)
    context = None
    if not args.library:
        import rclpy

        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        context = rclpy.Context()
        rclpy.init(context=context)
    low, high = args.lidar_noise
    print(
        f"maps and worlds in {out}; encoder noise {args.encoder_noise}, slip {args.slip}, budget {args.budget} s"
        + (f"; slam {slam_overrides}" if slam_overrides else "")
    )
    print(
        f"{'run':14s} {'noise':>5s} {'done s':>7s} {'known':>6s} {'precise':>7s} {'walls':>6s} {'coll':>4s} "
        f"{'gave up':>7s} {'wall s':>6s}" + ("  closures pose err  node err mean/max" if args.library else "")
    )
    try:
        for family in args.families:
            for k, seed in enumerate(args.seeds):
                noise = low + (high - low) * (k / max(1, len(args.seeds) - 1))
                case = (family, seed, noise, args.encoder_noise, args.slip, args.budget, out, args.resolution)
                if args.library:
                    r = run_library(*case, args.verbose, slam_overrides, args.record)
                else:
                    r = run(context, *case, slam_overrides)
                if "error" in r:
                    print(f"{r['name']:14s} {r['error']}", flush=True)
                    continue
                done = f"{r['done']:7.1f}" if r["done"] is not None else f"{'-':>7s}"
                print(
                    f"{r['name']:14s} {noise:5.3f} {done} {r.get('known', math.nan):6.3f} "
                    f"{r.get('precise', math.nan):7.3f} {r.get('walls', math.nan):6.3f} {r['collisions']:4d} "
                    f"{r['given_up']:7d} {r['wall']:6.0f}"
                    + (
                        f"  {r['closures']:8d} {r['pose_error']:8.3f}  "
                        f"{r['node_error'][0]:.3f} / {r['node_error'][1]:.3f}"
                        if args.library and "node_error" in r
                        else ""
                    ),
                    flush=True,
                )
                if args.navigate and (out / f"{r['name']}.yaml").exists():
                    print(f"{'':14s} {navigate(family, seed, noise, args, out / (r['name'] + '.yaml'))}", flush=True)
    finally:
        if context is not None:
            context.try_shutdown()
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores)")


if __name__ == "__main__":
    main()
