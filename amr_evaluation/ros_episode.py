"""An episode through the ROS nodes: the controller's amr-bringup stack, composed, in a child process of its own.

The stack (``maze_sim`` for the wall follower, ``maze_localization``, ``maze_navigation``) is the shipped
bringup file with the spec's world (written to a temporary file when generated), parameters (one temporary
parameter file for the controller's nodes and the simulator: seed, noise, slip), in lockstep on simulated
time. The child (``python -m amr_evaluation.ros_episode SPEC RECORD``) composes it as ``amr-bringup
--composed`` does (amr_bringup's ComposedStack and LifecycleManager) together with an observer of
``/simulator/status``, created before the lifecycle manager starts anything: in lockstep the simulator runs
as fast as the loop allows from its activation on, and an observer in another process could miss the first
seconds while discovery matches it. The episode ends at the first status that reaches the duration, the
goal, or ``max_collisions``; the record is made from it (goal, times, collisions, distance, the first
localized declaration and the estimate's error) and written as JSON for the parent. ``extra.slowest_step`` is the
longest wall-clock wait between two of the simulator's statuses and the simulated time it ended at ([s, t]): a step
that waited for a lost /pose or an unanswered observation shows there (under load a few tenths of a second at the
first step: the filter's first, global update).

Each episode takes a ROS domain of its own for its lifetime: the first free one of
``AMR_EVALUATE_ROS_DOMAINS`` (``first-last``, default 120-199), claimed with a lock file in the temporary
directory, so parallel workers of one machine never share a DDS graph. The child's environment is this
one without the ROS wheels' bootstrap markers (amr_util.environment), plus its ROS_DOMAIN_ID and
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST.

The ``command`` controller is a user's own node (``--run 'command=python3 student.py'``): ``maze_sim`` without
the wall follower, the command started in the episode's domain (its directory, this environment) before the
stack, its output kept. Lockstep by default (the simulator steps once per /cmd_vel: the node must answer every
observation, as a node publishing from its scan callback does), or ``clock: realtime`` (the simulator's timer
at ``pace`` x real time, the node's own timers free); plain Twist on /cmd_vel unless ``cmd_vel_stamped``. A node
that sends no /cmd_vel for ``answer_timeout`` wall-clock s (default 10), or exits, ends the episode with a record
saying so (``reason``; goal not reached), never a hang.

The navigation option ``goal_after`` (an idle stretch: no goal until then) clears the navigator's world goal topic
and gives the world's goal to the composed navigator node's core at its first observation at or after that time
(episode.give_goal_after, as the library loop's); meanwhile the navigator answers the observations it gives nobody
(``nobody_drives: zero``), so the world goes on at zero velocity as the library's does.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import math
import os
import shlex
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import yaml

from amr_util.environment import child_environment

STACKS = {
    "wall_follower": "maze_sim",
    "localization": "maze_localization",
    "navigation": "maze_navigation",
    "command": "maze_sim",
}
CLOCKS = ("lockstep", "realtime")
"""command: the simulator's modes a user's node may be run in."""
ANSWER_TIMEOUT = 10.0
"""command: wall-clock s without a /cmd_vel after which the node is given up (the record says so)."""
DOMAINS_VARIABLE = "AMR_EVALUATE_ROS_DOMAINS"
DEFAULT_DOMAINS = "120-199"
STARTUP_TIMEOUT = 60.0
"""wall-clock s for the stack to come up and publish its first status."""
STALL_TIMEOUT = 30.0
"""wall-clock s without simulated time advancing before the episode is given up."""
LOCKSTEP_WAIT = 20.0
"""wall-clock s a lockstep step of an episode waits for the filter's /pose or the navigator's plan (LOCKSTEP_WAITS)."""
LOCKSTEP_WAITS = {
    "maze_localization": {"simulator.lockstep_pose_wait": LOCKSTEP_WAIT},
    "maze_navigation": {"simulator.lockstep_pose_wait": LOCKSTEP_WAIT, "navigator.plan_timeout": LOCKSTEP_WAIT},
}
"""What a lockstep step of each stack waits for, and how long, as the library loop waits for it: the filter's /pose
of the last observation, and the navigator's plan (its status, which the controllers answer, waits for ~/plan). The
stacks' own 1 s and 10 s are made for a person watching; a loaded machine exceeds them, and a step that went on
without the /pose, or a plan given up, is another run. LOCKSTEP_WAIT is below STALL_TIMEOUT: a /pose lost on its way
(sent before the simulator's subscription matched) costs that much wall clock, not the episode."""


KERNEL_RUN = 0.5
"""simulated s of the spec's library episode run before the stack starts, to load or compile the numba kernels its
nodes call (_compile_kernels): the filter's first updates and first localized one, the first plan and command."""


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
    raise RosEpisodeError(
        f"every ROS domain of {DOMAINS_VARIABLE} ({os.environ.get(DOMAINS_VARIABLE, DEFAULT_DOMAINS)}) "
        "is held by another episode: widen the range or run fewer workers"
    )


def _world_file(spec, directory: Path) -> str:
    from amr_evaluation.worlds import build_world, with_goal, world_dict

    data = world_dict(spec.world)
    if data is None and spec.goal is None:
        return spec.world["file"]
    if data is None:
        from amr_maps.world import resolve_world_path

        data = yaml.safe_load(resolve_world_path(spec.world["file"]).read_text(encoding="utf-8"))
    if spec.goal is not None:
        world, costmap = build_world(spec.world), None
        if spec.controller == "navigation" and isinstance(spec.goal, str):  # placed as the library places it
            from amr_evaluation.episode import navigation_planner

            costmap = navigation_planner(spec, world).costmap
        world = with_goal(world, spec.goal, spec.seed, costmap)
        data["goal"] = [world.goal.x, world.goal.y, world.goal.radius]
    path = directory / "world.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return str(path)


def stack_of(spec, directory: Path) -> tuple[str, dict[str, str]]:
    """(stack name, its arguments) of an episode, its files written into ``directory``."""
    from amr_evaluation.worlds import world_hand
    from amr_util.parameter_file import node_parameters
    from amr_util.share import share_directory

    stack = STACKS.get(spec.controller)
    if stack is None:
        raise RosEpisodeError(
            f"mode ros: controller {spec.controller!r} has no stack (ros mode runs "
            f"{', '.join(STACKS)}); run it at library level"
        )
    parameters = {node: dict(values) for node, values in spec.parameters.items() if node != "command"}
    wall = parameters.get("wall_follower", {})
    if wall.get("simulation") is False:
        raise RosEpisodeError(
            "mode ros: this wall follower configuration has simulation: false (a timer on real "
            "time, plain Twist); the lockstep stacks take simulation: true configurations "
            "(rehearse the real one with amr-bringup real_robot_sim)"
        )
    hand = world_hand(spec.world)
    if hand is not None and "wall_follower" in parameters:
        parameters["wall_follower"]["preferred_wall"] = hand
    parameters.get("planner", {}).pop("world", None)  # the stack's world argument sets the planner's map
    parameters.get("particle_filter", {}).pop("world", None)
    simulator = node_parameters(share_directory("amr_simulation") / "config" / "simulator.yaml", "simulator")
    simulator["seed"] = spec.seed
    simulator["lidar"] = {**simulator.get("lidar", {}), "noise_std": spec.lidar_noise}
    simulator["encoders"] = {**simulator.get("encoders", {}), "noise": spec.encoder_noise, "slip": spec.slip}
    if spec.controller == "command":
        clock = spec.options.get("clock", "lockstep")
        if clock not in CLOCKS:
            raise RosEpisodeError(f"option clock: expected one of {', '.join(CLOCKS)}, got {clock!r}")
        simulator.update(mode=clock, cmd_vel_stamped=bool(spec.options.get("cmd_vel_stamped", False)))
        if clock == "realtime":
            simulator["pace"] = float(spec.options.get("pace", 1.0))
        if "beams" in spec.options:
            simulator["lidar"]["beams"] = int(spec.options["beams"])
    parameters["simulator"] = simulator
    if "particle_filter" in parameters:
        parameters["particle_filter"]["seed"] = spec.seed
    params_file = directory / "parameters.yaml"
    params_file.write_text(
        yaml.safe_dump({node: {"ros__parameters": values} for node, values in parameters.items()}), encoding="utf-8"
    )
    arguments = {"world": _world_file(spec, directory)}
    if spec.options.get("map"):  # a saved map served instead of the world's (the stack's map:=)
        arguments["map"] = str(spec.options["map"])
    arguments.update({f"{node}_params_file": str(params_file) for node in parameters})
    return stack, arguments


def run_ros(spec) -> dict[str, Any]:
    """The record's figures of ``spec`` run through its stack in a child process (see the module docstring)."""
    import json

    with tempfile.TemporaryDirectory(prefix="amr_evaluate_") as scratch, claimed_domain() as domain:
        directory = Path(scratch)
        stack_of(spec, directory)  # refuse what cannot run here, before a process is started
        (directory / "spec.json").write_text(json.dumps(spec.to_dict()), encoding="utf-8")
        result = directory / "record.json"
        env = child_environment(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        with (directory / "stack.log").open("w+") as log:
            process = subprocess.Popen(
                [sys.executable, "-m", "amr_evaluation.ros_episode", str(directory / "spec.json"), str(result)],
                stdout=log,
                stderr=subprocess.STDOUT,
                env=env,
                start_new_session=True,
            )
            try:
                process.wait(timeout=STARTUP_TIMEOUT + spec.duration * 2.0 + 60.0)
            except subprocess.TimeoutExpired:
                stop_process(process)
            log.seek(0)
            said = log.read()[-1500:]
        if process.returncode != 0 or not result.exists():
            raise RosEpisodeError(f"the stack's process exited with code {process.returncode}: {said}")
        figures = json.loads(result.read_text(encoding="utf-8"))
    figures["extra"] = {**figures.get("extra", {}), "ros_domain": domain}
    return figures


def stop_process(process: subprocess.Popen, timeout: float = 15.0) -> None:
    """Ctrl-C to a stack's process (amr-bringup shuts its nodes down in order), killed after `timeout` s."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def _episode_in_this_process(spec, directory: Path) -> dict[str, Any]:
    """The child's work: the stack composed with the observer, started, watched, taken down."""
    import rclpy
    from rclpy.parameter import Parameter

    from amr_bringup.bringup import ComposedStack, Console, check_composable
    from amr_bringup.lifecycle_manager import LifecycleManager
    from amr_bringup.stack_config import load_bringup
    from amr_evaluation.episode import goal_after
    from amr_interfaces.msg import SimulatorStatus
    from amr_util.executors import NodeSpinners
    from amr_util.stop_signals import Flag

    name, arguments = stack_of(spec, directory)
    overrides = {key: str(value) for key, value in LOCKSTEP_WAITS.get(name, {}).items()}
    after = goal_after(spec) if spec.controller == "navigation" else None
    if after is not None:
        overrides["navigator.world_goal_topic"] = ""  # the goal comes at `after` (_goal_given_after)
    bringup = load_bringup(name).with_overrides(arguments, overrides)
    command = spec.parameters.get("command") if spec.controller == "command" else None
    if command is not None:  # the user's node drives instead of the shipped wall follower
        bringup = dataclasses.replace(
            bringup,
            nodes=tuple(node for node in bringup.nodes if node.name != "wall_follower"),
            node_startup_order=tuple(node for node in bringup.node_startup_order if node != "wall_follower"),
        )
    check_composable(bringup)
    compiled = _compile_kernels(spec)
    max_collisions = int(spec.options.get("max_collisions", 5)) if spec.controller == "navigation" else None
    lock = threading.Lock()
    state: dict[str, Any] = {
        "status": None,
        "reason": "",
        "first_error": None,
        "max_error": 0.0,
        "commands": 0,
        "last_command": None,
        "last_status_wall": None,
        "slowest_step": (0.0, 0.0),
    }

    def on_command(message) -> None:
        with lock:
            state["commands"] += 1
            state["last_command"] = time.monotonic()

    def on_status(message: SimulatorStatus) -> None:
        # lockstep runs ahead of this thread: the record is the first status that ends the episode
        with lock:
            if state["reason"]:
                return
            state["status"] = message
            now, last = time.monotonic(), state["last_status_wall"]
            if last is not None and now - last > state["slowest_step"][0]:
                state["slowest_step"] = (now - last, message.sim_time)
            state["last_status_wall"] = now
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

    rclpy.init(args=[])
    spinners = NodeSpinners()
    stack = controller = None
    controller_log = directory / "controller.log"
    try:
        observer = rclpy.create_node("amr_evaluate_observer")
        observer.create_subscription(SimulatorStatus, "simulator/status", on_status, 1000)
        if command is not None:
            from geometry_msgs.msg import Twist, TwistStamped

            stamped = bool(spec.options.get("cmd_vel_stamped", False))
            observer.create_subscription(TwistStamped if stamped else Twist, "cmd_vel", on_command, 100)
            controller = _start_controller(command, controller_log)
        spinners.add_node(observer)
        stack = ComposedStack(bringup, Console(live=False))
        for node in stack.nodes:
            spinners.add_node(node)
        before_activate = (lambda name: None) if after is None else _goal_given_after(stack, after, arguments["world"])
        manager = LifecycleManager(
            before_activate=before_activate,
            cli_args=["--ros-args", "-r", f"__node:={bringup.manager_name}"],
            parameter_overrides=[Parameter(k, value=v) for k, v in bringup.manager_parameters().items()],
        )
        spinners.add_node(manager)
        steps = manager.startup()
        if not manager.started:
            failed = next((step for step in steps if not step.ok), None)
            raise RosEpisodeError(
                f"startup failed at {failed.transition} of {failed.node}: {failed.detail}"
                if failed
                else "startup failed"
            )
        deadline, last_time = time.monotonic() + STARTUP_TIMEOUT, -1.0
        began = time.monotonic()
        answer_timeout = float(spec.options.get("answer_timeout", ANSWER_TIMEOUT))
        while True:
            time.sleep(0.02)
            with lock:
                status, reason = state["status"], state["reason"]
                if not reason and controller is not None:
                    reason = state["reason"] = _controller_problem(
                        controller, observer, state, began, answer_timeout, spec.options
                    )
            if reason:
                break
            if stack.failure():
                raise RosEpisodeError(stack.failure())
            if status is None or status.sim_time <= last_time:
                if time.monotonic() > deadline:
                    raise RosEpisodeError(
                        "no progress on /simulator/status"
                        if status
                        else f"no /simulator/status within {STARTUP_TIMEOUT:.0f} s"
                    )
                continue
            last_time, deadline = status.sim_time, time.monotonic() + STALL_TIMEOUT
        manager.shutdown()
    finally:
        if controller is not None:
            stop_process(controller, timeout=5.0)
        spinners.shutdown()
        if stack is not None:
            stack.stop(Flag())
        rclpy.shutdown()
    if status is None:  # a user's node gave up before the first observation
        status = SimulatorStatus()
    figures: dict[str, Any] = {
        "time": status.sim_time,
        "reason": reason,
        "collisions": int(status.collisions),
        "distance": float(status.distance_travelled),
    }
    if spec.goal is not None or _world_has_goal(spec):
        figures.update(
            goal_reached=bool(status.goal_reached), time_to_goal=status.sim_time if status.goal_reached else None
        )
    wait, at = state["slowest_step"]
    figures["extra"] = {"slowest_step": [round(wait, 3), at], "kernels_loaded": round(compiled, 3)}
    if command is not None:
        output = controller_log.read_text(encoding="utf-8", errors="replace") if controller_log.exists() else ""
        figures["extra"].update(
            commands=state["commands"],
            clock=spec.options.get("clock", "lockstep"),
            controller_output=output[-1000:],
        )
    if status.localization_enabled and status.first_localized_time >= 0.0:
        figures.update(
            time_to_localized=status.first_localized_time,
            localization_error=state["first_error"],
            localization_error_max=state["max_error"],
        )
    return figures


def _compile_kernels(spec) -> float:
    """The numba kernels the stack's nodes call (the wall follower's scan kernels, the filter's likelihood field and
    place search, the simulator's ray casting) loaded in this process before the stack starts, by the first KERNEL_RUN
    s of the spec's library episode (the same classes the composed nodes are): the wall-clock s it took.

    The kernels are cached per source version (numba cache=True). With the cache cold (a kernel's module edited since
    the last run, a clean clone) the first call compiles for seconds, holding the GIL; inside the lockstep loop the
    first observation would wait that long, past lockstep_resend_period and LOCKSTEP_WAIT. Compiled here, that wait
    is over before the loop's clock starts; with the cache warm this costs about a second (the simulator and the
    filter built once more). Measured: docs/amr_evaluation.md."""
    began = time.monotonic()
    if spec.controller in ("wall_follower", "localization", "navigation"):
        from amr_evaluation.episode import run_episode

        run_episode(dataclasses.replace(spec, mode="library", duration=min(spec.duration, KERNEL_RUN)))
    else:  # a user's node: the simulator's ray casting
        from amr_evaluation.episode import simulator_for
        from amr_evaluation.worlds import build_world

        simulator_for(spec, build_world(spec.world))
    return time.monotonic() - began


def _goal_given_after(stack, after: float, world: str):
    """before_activate of the option goal_after: the navigator node's core (configured, not active yet) is given the
    world's goal (of the file the simulator runs) at its first observation at or after `after` s."""
    from amr_evaluation.episode import give_goal_after
    from amr_maps.world import load_world, resolve_world_path

    goal = load_world(resolve_world_path(world)).goal

    def before_activate(name: str) -> None:
        if name.strip("/") != "navigator":
            return
        node = next(node for node in stack.nodes if node.get_name() == "navigator")
        give_goal_after(node.core, after, (goal.x, goal.y), node.get_logger().info)

    return before_activate


def _start_controller(command: dict, log: Path) -> subprocess.Popen:
    """The user's command, in its directory, in this process's ROS domain, its output into `log`."""
    try:
        with log.open("w") as stream:
            return subprocess.Popen(
                command["argv"],
                cwd=command["cwd"],
                stdout=stream,
                stderr=subprocess.STDOUT,
                env=child_environment(),
                start_new_session=True,
            )
    except OSError as error:
        raise RosEpisodeError(
            f"the controller's command {shlex.join(command['argv'])!r} (in {command['cwd']}) could not start: {error}"
        ) from error


def _controller_problem(
    controller: subprocess.Popen, observer, state: dict, began: float, answer_timeout: float, options: dict
) -> str:
    """Why a user's node ends the episode now ('' while it drives): it exited, or it sent no /cmd_vel for
    answer_timeout wall-clock s (naming the type the simulator takes when the node publishes another)."""
    code = controller.poll()
    if code is not None:
        return f"the controller exited with code {code} after {state['commands']} commands"
    since = state["last_command"] if state["last_command"] is not None else began
    if time.monotonic() - since <= answer_timeout:
        return ""
    wanted = "geometry_msgs/msg/TwistStamped" if options.get("cmd_vel_stamped", False) else "geometry_msgs/msg/Twist"
    others = sorted({info.topic_type for info in observer.get_publishers_info_by_topic("/cmd_vel")} - {wanted})
    wrong = f" (it publishes {', '.join(others)} on /cmd_vel; the simulator takes {wanted})" if others else ""
    if state["commands"] == 0:
        return f"the controller never answered: no /cmd_vel within {answer_timeout:g} s{wrong}"
    return f"the controller stopped answering: no /cmd_vel for {answer_timeout:g} s after {state['commands']} commands"


def _world_has_goal(spec) -> bool:
    from amr_evaluation.worlds import build_world

    return build_world(spec.world).goal is not None


def main(argv: list[str] | None = None) -> int:
    """The child process: SPEC (a spec's JSON file) in, RECORD (the figures' JSON file) out."""
    import json

    from amr_evaluation.episode import EpisodeSpec

    spec_path, record_path = (argv if argv is not None else sys.argv[1:])[:2]
    spec = EpisodeSpec.from_dict(json.loads(Path(spec_path).read_text(encoding="utf-8")))
    figures = _episode_in_this_process(spec, Path(spec_path).parent)
    Path(record_path).write_text(json.dumps(figures), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
