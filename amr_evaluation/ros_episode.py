"""An episode through the ROS nodes: the controller's amr-bringup stack in a child process, watched over DDS.

The stack (``maze_sim`` for the wall follower, ``maze_localization``, ``maze_navigation``) runs composed
(``amr-bringup <stack> --composed``) in lockstep on simulated time, with the spec's world (written to a
temporary file when generated), parameters (one temporary parameter file for the controller's nodes),
seed and noise. This process follows ``/simulator/status`` until the duration, the goal, or
``max_collisions``, then stops the stack with SIGINT (as Ctrl-C would) and makes the record from the
status: goal, times, collisions, distance, the first localized declaration and the estimate's error.

Each episode takes a ROS domain of its own for its lifetime: the first free one of
``AMR_EVALUATE_ROS_DOMAINS`` (``first-last``, default 120-199), claimed with a lock file in the temporary
directory, so parallel workers of one machine never share a DDS graph. The child's environment is this
one without the ROS wheels' bootstrap markers (amr_util.environment), plus its ROS_DOMAIN_ID and
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST.
"""

from __future__ import annotations

import contextlib
import fcntl
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Iterator

import yaml

from amr_util.environment import child_environment

STACKS = {"wall_follower": "maze_sim", "localization": "maze_localization", "navigation": "maze_navigation"}
DOMAINS_VARIABLE = "AMR_EVALUATE_ROS_DOMAINS"
DEFAULT_DOMAINS = "120-199"
STARTUP_TIMEOUT = 60.0
"""wall-clock s for the stack to come up and publish its first status."""
STALL_TIMEOUT = 30.0
"""wall-clock s without simulated time advancing before the episode is given up."""


class RosEpisodeError(RuntimeError):
    """The stack did not come up, stopped advancing, or the spec cannot run through ROS (named)."""


def domain_range() -> range:
    text = os.environ.get(DOMAINS_VARIABLE, DEFAULT_DOMAINS)
    try:
        first, last = (int(v) for v in text.split("-"))
    except ValueError as error:
        raise RosEpisodeError(f"{DOMAINS_VARIABLE}={text!r}: expected first-last, e.g. 48-55") from error
    if not 0 <= first <= last <= 232:
        raise RosEpisodeError(f"{DOMAINS_VARIABLE}={text!r}: domains lie in 0-232")
    return range(first, last + 1)


@contextlib.contextmanager
def claimed_domain() -> Iterator[int]:
    """A ROS domain no other episode of this machine holds, until the block ends."""
    for domain in domain_range():
        path = Path(tempfile.gettempdir()) / f"amr_evaluate_domain_{domain}.lock"
        stream = path.open("a")
        try:
            fcntl.flock(stream, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            stream.close()
            continue
        try:
            yield domain
        finally:
            fcntl.flock(stream, fcntl.LOCK_UN)
            stream.close()
        return
    raise RosEpisodeError(f"every ROS domain of {DOMAINS_VARIABLE} ({os.environ.get(DOMAINS_VARIABLE, DEFAULT_DOMAINS)}) "
                          "is held by another episode: widen the range or run fewer workers")


def _world_file(spec, directory: Path) -> str:
    from amr_evaluation.worlds import build_world, with_goal, world_dict

    data = world_dict(spec.world)
    if data is None and spec.goal is None:
        return spec.world["file"]
    if data is None:
        from amr_simulation.world import resolve_world_path

        data = yaml.safe_load(resolve_world_path(spec.world["file"]).read_text(encoding="utf-8"))
    if spec.goal is not None:
        world = with_goal(build_world(spec.world), spec.goal, spec.seed)
        data["goal"] = [world.goal.x, world.goal.y, world.goal.radius]
    path = directory / "world.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return str(path)


def command_of(spec, directory: Path) -> list[str]:
    """The amr-bringup command line of an episode (its files written into ``directory``)."""
    from amr_evaluation.worlds import world_hand

    stack = STACKS.get(spec.controller)
    if stack is None:
        raise RosEpisodeError(f"mode ros: controller {spec.controller!r} has no stack (ros mode runs "
                              f"{', '.join(STACKS)}); run it at library level")
    parameters = {node: dict(values) for node, values in spec.parameters.items()}
    wall = parameters.get("wall_follower", {})
    if wall.get("simulation") is False:
        raise RosEpisodeError("mode ros: this wall follower configuration has simulation: false (a timer on real "
                              "time, plain Twist); the lockstep stacks take simulation: true configurations "
                              "(rehearse the real one with amr-bringup real_robot_sim)")
    hand = world_hand(spec.world)
    if hand is not None and "wall_follower" in parameters:
        parameters["wall_follower"]["preferred_wall"] = hand
    parameters.get("planner", {}).pop("world", None)  # the stack's world argument sets the planner's map
    parameters.get("particle_filter", {}).pop("world", None)
    from amr_util.parameter_file import node_parameters
    from amr_util.share import share_directory

    simulator = node_parameters(share_directory("amr_simulation") / "config" / "simulator.yaml", "simulator")
    simulator["seed"] = spec.seed
    simulator["lidar"] = {**simulator.get("lidar", {}), "noise_std": spec.lidar_noise}
    simulator["encoders"] = {**simulator.get("encoders", {}), "noise": spec.encoder_noise, "slip": spec.slip}
    parameters["simulator"] = simulator
    if "particle_filter" in parameters:
        parameters["particle_filter"]["seed"] = spec.seed
    params_file = directory / "parameters.yaml"
    params_file.write_text(yaml.safe_dump({node: {"ros__parameters": values} for node, values in parameters.items()}),
                           encoding="utf-8")
    command = [sys.executable, "-m", "amr_bringup.bringup", stack, f"world:={_world_file(spec, directory)}"]
    command += [f"{node}_params_file:={params_file}" for node in parameters]
    return command + ["--composed"]


def run_ros(spec) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="amr_evaluate_") as scratch, claimed_domain() as domain:
        directory = Path(scratch)
        command = command_of(spec, directory)
        log = (directory / "stack.log").open("w+")
        env = child_environment(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
        try:
            figures = _watch(spec, domain, process)
        except RosEpisodeError as error:
            log.flush()
            log.seek(0)
            tail = log.read()[-1500:]
            raise RosEpisodeError(f"{error}; the stack said: {tail}") from error
        finally:
            _stop(process)
            log.close()
    figures["extra"] = {**figures.get("extra", {}), "ros_domain": domain}
    return figures


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=15.0)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def _watch(spec, domain: int, process: subprocess.Popen) -> dict[str, Any]:
    import rclpy
    from amr_interfaces.msg import SimulatorStatus
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor

    context = Context()
    rclpy.init(context=context, domain_id=domain)
    lock = threading.Lock()
    state: dict[str, Any] = {"status": None, "first_error": None, "max_error": 0.0}

    max_collisions = int(spec.options.get("max_collisions", 5)) if spec.controller == "navigation" else None

    def on_status(message: SimulatorStatus) -> None:
        # lockstep runs ahead of this thread: the record is the first status that ends the episode
        with lock:
            if state.get("reason"):
                return
            state["status"] = message
            if message.localization_enabled and message.localized and math.isfinite(message.position_error):
                if state["first_error"] is None:
                    state["first_error"] = message.position_error
                state["max_error"] = max(state["max_error"], message.position_error)
            if message.goal_reached:
                state["reason"] = "goal region reached"
            elif message.sim_time >= spec.duration - 1e-9:
                state["reason"] = f"time limit {spec.duration:g} s"
            elif max_collisions is not None and message.collisions >= max_collisions:
                state["reason"] = f"{message.collisions} collisions"

    node = rclpy.create_node("amr_evaluate_observer", context=context)
    node.create_subscription(SimulatorStatus, "simulator/status", on_status, 1000)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        deadline = time.monotonic() + STARTUP_TIMEOUT
        last_time = -1.0
        while True:
            time.sleep(0.05)
            with lock:
                status, reason = state["status"], state.get("reason")
            if reason:
                break
            if process.poll() is not None:
                raise RosEpisodeError(f"the stack exited with code {process.returncode}")
            if status is None or status.sim_time <= last_time:
                if time.monotonic() > deadline:
                    raise RosEpisodeError("no progress on /simulator/status" if status else
                                          f"no /simulator/status within {STARTUP_TIMEOUT:.0f} s")
                continue
            last_time, deadline = status.sim_time, time.monotonic() + STALL_TIMEOUT
        with lock:
            first_error, max_error = state["first_error"], state["max_error"]
    finally:
        executor.shutdown(timeout_sec=5.0)
        spinner.join(timeout=5.0)
        node.destroy_node()
        rclpy.shutdown(context=context)
    figures: dict[str, Any] = {
        "time": status.sim_time, "reason": reason, "collisions": int(status.collisions),
        "distance": float(status.distance_travelled),
    }
    has_goal = spec.goal is not None or _world_has_goal(spec)
    if has_goal:
        figures.update(goal_reached=bool(status.goal_reached),
                       time_to_goal=status.sim_time if status.goal_reached else None)
    if status.localization_enabled and status.first_localized_time >= 0.0:
        figures.update(time_to_localized=status.first_localized_time, localization_error=first_error,
                       localization_error_max=max_error)
    return figures


def _world_has_goal(spec) -> bool:
    from amr_evaluation.worlds import build_world

    return build_world(spec.world).goal is not None
