"""amr_evaluation figures: sweep throughput, the runner's overhead per episode, Gymnasium steps per second.

1. Episodes per second with 1 and 2 local workers and on a loopback Dask cluster (a scheduler and one
   `dask worker --nworkers 2 --nthreads 1`, started here from the venv on 127.0.0.1, free ports), the same
   episodes each time: wall-follower episodes of 10 simulated seconds on generated mazes.
2. The runner's overhead per episode (goal: under 5 % of a 10-second episode): the sweep's wall time per
   episode with 1 worker (in process) minus the episodes' own time (each record's wall_time: world, controller,
   closed loop), and the episode's own set-up against the bare closed loop (amr_evaluation.wall_follower_loop).
3. amr/Maze-v0 steps per second: one environment, and make_vec with 2 copies, sync and async; and the returns of
   its reference policies (amr_evaluation.gym_env.REFERENCE_POLICIES) on open_room, seed 0, the defaults.
4. A student's node graded through ROS (controller `command`, lockstep, one worker): the wall clock an episode
   takes beyond its run, fitted from two episode lengths (a node driving straight on at each scan, open_room, a goal
   1 m ahead it does not reach in either). Run under ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; the episodes take
   their domains from AMR_EVALUATE_ROS_DOMAINS (default 120-199).

Prints, asserts nothing; quotes the load average (the machine is shared).

    python bench/bench_evaluate.py [--episodes 16] [--seconds 10] [--steps 3000] [--no-dask] [--no-gym] [--no-student]
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from amr_evaluation import configs
from amr_evaluation.episode import EpisodeSpec, run_episode, wall_follower_config
from amr_evaluation.records import without_timing
from amr_evaluation.runner import run_sweep
from amr_evaluation.wall_follower_loop import run
from amr_evaluation.worlds import build_world, forget_generated_worlds
from amr_maps.maze_families import FAMILIES
from amr_util.environment import child_environment

ROOT = Path(__file__).resolve().parents[1]


def specs_of(count: int, seconds: float, first_seed: int = 0) -> list[EpisodeSpec]:
    label, parameters = configs.resolve("wall_follower", "sim")
    return [
        EpisodeSpec(
            "wall_follower",
            label,
            parameters,
            {"family": FAMILIES[i % len(FAMILIES)], "seed": first_seed + i, "options": {"hand": "right"}},
            None,
            first_seed + i,
            0.01,
            0.02,
            0.05,
            seconds,
        )
        for i in range(count)
    ]


def timed_sweep(specs, directory: Path, name: str, **where) -> tuple[float, list[dict]]:
    forget_generated_worlds()  # every sweep draws its mazes (a forked pool would inherit them drawn)
    began = time.perf_counter()
    records = run_sweep(specs, directory / f"{name}.jsonl", progress=False, **where)
    return time.perf_counter() - began, records


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def loopback_cluster(directory: Path):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    binary = Path(sys.executable).parent / "dask"
    env = child_environment()
    log = (directory / "dask.log").open("w")
    began = time.perf_counter()
    processes = [
        subprocess.Popen(
            [str(binary), "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard", "--no-show"],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        ),
        subprocess.Popen(
            [
                str(binary),
                "worker",
                address,
                "--nworkers",
                "2",
                "--nthreads",
                "1",
                "--host",
                "127.0.0.1",
                "--no-dashboard",
                "--local-directory",
                str(directory),
            ],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        ),
    ]
    from distributed import Client

    with Client(address, timeout="30s") as client:
        client.wait_for_workers(2, timeout=60)
    return address, processes, time.perf_counter() - began


def stop(processes) -> None:
    for process in reversed(processes):
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGTERM)
    for process in processes:
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)


def throughput(episodes: int, seconds: float, dask: bool) -> None:
    print(
        f"== sweep throughput: {episodes} wall-follower episodes of {seconds:g} s simulated (generated mazes, "
        f"LiDAR 0.01 m, encoders 0.02, slip 0.05); load {os.getloadavg()[0]:.1f}"
    )
    specs = specs_of(episodes, seconds)
    run_episode(specs_of(1, 1.0, 10_000)[0])  # imports and compiled kernels warm in this process
    with tempfile.TemporaryDirectory() as scratch:
        directory = Path(scratch)
        one_time, one = timed_sweep(specs, directory, "one", workers=1)
        print(f"1 worker (in process): {one_time:6.1f} s, {episodes / one_time:5.2f} episodes/s")
        two_time, two = timed_sweep(specs, directory, "two", workers=2)
        same = [without_timing(r) for r in one] == [without_timing(r) for r in two]
        print(
            f"2 local workers:       {two_time:6.1f} s, {episodes / two_time:5.2f} episodes/s "
            f"({one_time / two_time:.2f}x; records {'identical' if same else 'DIFFER'}; {_overhead(two_time, 2, two)})"
        )
        if dask:
            address, processes, start = loopback_cluster(directory)
            try:
                timed_sweep(specs_of(2, 1.0, 20_000), directory, "warm", scheduler=address)  # workers import once
                dask_time, remote = timed_sweep(specs, directory, "dask", scheduler=address)
            finally:
                stop(processes)
            same = [without_timing(r) for r in one] == [without_timing(r) for r in remote]
            print(
                f"loopback Dask, 2 worker processes: {dask_time:6.1f} s, {episodes / dask_time:5.2f} episodes/s "
                f"({one_time / dask_time:.2f}x; records {'identical' if same else 'DIFFER'}; "
                f"{_overhead(dask_time, 2, remote)}; the cluster took {start:.1f} s to start)"
            )
        own = [r["wall_time"] for r in one]
        per_episode = one_time / episodes
        overhead = per_episode - statistics.mean(own)
        print(
            f"== runner overhead, 1 worker: {1e3 * per_episode:.1f} ms per episode, of which the episode itself "
            f"{1e3 * statistics.mean(own):.1f} ms: {1e3 * overhead:.2f} ms ({100 * overhead / per_episode:.2f} % "
            "of the episode; goal < 5 %)"
        )
        runner_only(directory, one[0], statistics.mean(own))
    set_up(specs)


def _overhead(elapsed: float, workers: int, records: list[dict]) -> str:
    """Worker time per episode beyond the episode's own (its record's wall_time): pool, transport, records."""
    per_episode = elapsed * workers / len(records)
    extra = per_episode - statistics.mean(r["wall_time"] for r in records)
    return f"{1e3 * extra:.0f} ms per episode beyond its own ({100 * extra / per_episode:.1f} %)"


def runner_only(directory: Path, record: dict, episode_seconds: float, count: int = 2000) -> None:
    """The runner's own cost per episode, with an episode that returns a ready record at once: the key,
    the records file (json, write, flush; fsync once a second), the bookkeeping."""
    specs = specs_of(count, 10.0, 30_000)
    ready = {spec.key: {**record, "key": spec.key} for spec in specs}
    began = time.perf_counter()
    run_sweep(
        specs,
        directory / "runner_only.jsonl",
        progress=False,
        episode=lambda spec: ready[EpisodeSpec.from_dict(spec).key],
    )
    cost = (time.perf_counter() - began) / count
    print(
        f"   the runner alone (an episode that returns at once, {count} of them): {1e3 * cost:.3f} ms per episode, "
        f"{100 * cost / episode_seconds:.2f} % of a 10-second episode here ({1e3 * episode_seconds:.0f} ms)"
    )


def set_up(specs) -> None:
    """The episode's own set-up (spec to world and controller, the record) against the bare closed loop."""
    bare, whole = [], []
    for spec in specs:
        world = build_world(spec.world)
        config = wall_follower_config(spec)
        began = time.perf_counter()
        run(
            world,
            config,
            spec.duration,
            lidar_noise=spec.lidar_noise,
            encoder_noise=spec.encoder_noise,
            slip=spec.slip,
            seed=spec.seed,
        )
        bare.append(time.perf_counter() - began)
        began = time.perf_counter()
        run_episode(spec)
        whole.append(time.perf_counter() - began)
    extra = statistics.mean(whole) - statistics.mean(bare)
    print(
        f"== an episode against its bare closed loop: {1e3 * statistics.mean(whole):.1f} ms vs "
        f"{1e3 * statistics.mean(bare):.1f} ms: {1e3 * extra:.1f} ms ({100 * extra / statistics.mean(whole):.1f} %) "
        "to generate the maze, read the config and make the record"
    )


def gym_steps(steps: int) -> None:
    import gymnasium

    importlib.import_module("amr_evaluation.gym_env")  # registers amr/Maze-v0

    print(
        f"== amr/Maze-v0 steps per second ({steps} steps, random actions, 240 beams, generated mazes, "
        f"resets included); load {os.getloadavg()[0]:.1f}"
    )
    env = gymnasium.make("amr/Maze-v0", max_steps=500)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    began = time.perf_counter()
    resets = 0
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        if terminated or truncated:
            env.reset()
            resets += 1
    elapsed = time.perf_counter() - began
    print(f"single environment: {steps / elapsed:7.0f} steps/s ({resets} resets)")
    for mode in ("sync", "async"):
        envs = gymnasium.make_vec("amr/Maze-v0", num_envs=2, vectorization_mode=mode, max_steps=500)
        envs.reset(seed=0)
        began = time.perf_counter()
        for _ in range(steps // 2):
            envs.step(envs.action_space.sample())
        elapsed = time.perf_counter() - began
        envs.close()
        print(f"make_vec {mode:5s} x2:   {steps / elapsed:7.0f} steps/s (both copies together)")


def gym_returns() -> None:
    from amr_evaluation.gym_env import REFERENCE_POLICIES, MazeEnv, episode_return

    env = MazeEnv(world="open_room")
    print(f"== amr/Maze-v0 returns, open_room, seed 0, the defaults ({env.max_steps} steps at most)")
    for name, policy in REFERENCE_POLICIES.items():
        total, _, end = episode_return(env, policy, 0)
        how = "goal" if end["is_success"] else "contact" if end["collisions"] else "end"
        print(f"{name:18s} {total:7.1f}  ({how} at {end['time']:.1f} s)")


STUDENT = """
import rclpy
from geometry_msgs.msg import Twist
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

rclpy.init()
node = rclpy.create_node("student")
publisher = node.create_publisher(Twist, "cmd_vel", 10)
straight_on = Twist()
straight_on.linear.x = 0.2
node.create_subscription(LaserScan, "scan", lambda scan: publisher.publish(straight_on), qos_profile_sensor_data)
rclpy.spin(node)
"""
"""A student's node at its simplest: one command answering each scan."""


def student_overhead(durations=(1.5, 3.5)) -> None:
    print(
        f"== a student's node through ROS (lockstep, open_room, goal 1 m ahead, one worker); "
        f"load {os.getloadavg()[0]:.1f}"
    )
    with tempfile.TemporaryDirectory() as directory:
        (Path(directory) / "student.py").write_text(STUDENT, encoding="utf-8")
        label, parameters = configs.command_configuration(f"{sys.executable} student.py", directory)
        runs = []
        for duration in durations:
            spec = EpisodeSpec(
                "command", label, parameters, {"file": "open_room.yaml"}, goal=[-0.5, -1.0, 0.2], seed=1,
                duration=duration, options={"answer_timeout": 10.0}, mode="ros",
            )  # fmt: skip
            record = run_episode(spec)
            if record["error"]:
                print(f"{duration:4.1f} s: {record['error']}")
                return
            runs.append((record["time"], record["wall_time"]))
            print(f"{record['time']:5.2f} simulated s: {record['wall_time']:5.2f} s of wall clock ({record['reason']})")
    (short, short_wall), (long, long_wall) = runs
    per_second = (long_wall - short_wall) / (long - short)
    print(
        f"beyond the run: {short_wall - short * per_second:.1f} s of wall clock an episode "
        f"(the run: {per_second:.2f} s of wall clock a simulated s)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated s per episode")
    parser.add_argument("--steps", type=int, default=3000, help="Gymnasium steps per measurement")
    parser.add_argument("--no-dask", action="store_true")
    parser.add_argument("--no-gym", action="store_true")
    parser.add_argument("--no-student", action="store_true", help="no student's node through ROS")
    parser.add_argument("--only", choices=("returns", "student"), help="only that part")
    args = parser.parse_args()
    if args.only == "returns":
        return gym_returns()
    if args.only == "student":
        return student_overhead()
    throughput(args.episodes, args.seconds, not args.no_dask)
    if not args.no_gym:
        gym_steps(args.steps)
        gym_returns()
    if not args.no_student:
        student_overhead()


if __name__ == "__main__":
    main()
