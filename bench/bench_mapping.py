"""maze_mapping on generated maze families (issue 37): explore an unknown maze with slam + explorer + planner +
navigator + path follower, through ROS (the composed stack, lockstep on simulated time), and judge the saved map
against the world.

Each run: a world of amr_maps.maze_families (family, seed), LiDAR noise, encoder noise and slip, the stack
`maze_mapping world:=<it> save_to:=<dir>/<run>` until the explorer says `done` (it saves the map then) or the
simulated-time budget runs out. Printed per run:

- done: simulated s when the explorer said done (`-` if it never did: then the map is saved at the budget's end)
- known: share of the reachable free cells (the world rasterized at the map's resolution, free cells 8-connected
  to the start) that the saved map knows (free or occupied)
- precise: share of the saved map's occupied cells within one cell of a true wall
- walls: share of the true wall cells bordering reachable space that the saved map marks occupied within one cell
- collisions (the simulator's wall contacts), goals the explorer gave up, wall-clock s

The saved map is in slam's map frame, the odom frame of the first scan: the simulator's odometry starts at the
world's start pose, so it is the world's frame (what `maze_navigation world:=<world> map:=<run>.yaml` takes as
it is). Prints; asserts nothing.

    .venv/bin/python bench/bench_mapping.py [--families perfect loops rotated pillars open_room] [--seeds 0 1 2]
        [--lidar-noise 0.01 0.03] [--encoder-noise 0.02] [--slip 0.05] [--budget 900] [--resolution 0.025] [--out DIR]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from scipy import ndimage

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import rclpy
from amr_interfaces.msg import Frontiers, SimulatorStatus
from amr_interfaces.srv import SaveMap
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from amr_bringup.composed import composed_stack
from amr_maps.map_io import load_map
from amr_maps.maze_families import generate
from amr_maps.rasterize import rasterize_world
from amr_maps.world import world_from_dict
from amr_util.qos import reliable

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
) -> dict:
    """One maze_mapping run; the figures of the module docstring."""
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
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--resolution", type=float, default=None, help="slam's cells (m); default slam.yaml's")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="bench_mapping_"))
    out.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    context = rclpy.Context()
    rclpy.init(context=context)
    low, high = args.lidar_noise
    print(f"maps and worlds in {out}; encoder noise {args.encoder_noise}, slip {args.slip}, budget {args.budget} s")
    print(
        f"{'run':14s} {'noise':>5s} {'done s':>7s} {'known':>6s} {'precise':>7s} {'walls':>6s} {'coll':>4s} "
        f"{'gave up':>7s} {'wall s':>6s}"
    )
    try:
        for family in args.families:
            for k, seed in enumerate(args.seeds):
                noise = low + (high - low) * (k / max(1, len(args.seeds) - 1))
                r = run(context, family, seed, noise, args.encoder_noise, args.slip, args.budget, out, args.resolution)
                if "error" in r:
                    print(f"{r['name']:14s} {r['error']}", flush=True)
                    continue
                done = f"{r['done']:7.1f}" if r["done"] is not None else f"{'-':>7s}"
                print(
                    f"{r['name']:14s} {noise:5.3f} {done} {r.get('known', math.nan):6.3f} "
                    f"{r.get('precise', math.nan):7.3f} {r.get('walls', math.nan):6.3f} {r['collisions']:4d} "
                    f"{r['given_up']:7d} {r['wall']:6.0f}",
                    flush=True,
                )
    finally:
        context.try_shutdown()
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores)")


if __name__ == "__main__":
    main()
