"""amr-bringup: start a stack from its bringup file, bring it to active, keep it up, take it down.

    amr-bringup maze_sim                        # a shipped bringup (config/bringup/maze_sim.yaml)
    amr-bringup my_stack.yaml --composed        # every node in this one process
    amr-bringup real_robot --status --duration 30
    amr-bringup maze_sim --record out/run.mcap [--topics /scan /tf ...]   # a rosbag2 MCAP bag of the run
    amr-bringup maze_navigation --view          # and watch it in a browser: http://127.0.0.1:8080

By default each node is its own process, started as `ros2 run` would
(lib/<package>/<executable> --ros-args ...), its output prefixed with its name. With
--composed the node classes (NODE_CLASSES) are instantiated here, each spun on a thread of its
own (amr_util.executors). Either way the lifecycle manager (amr_bringup.lifecycle_manager)
runs inside this process: its startup result tells at once which node failed which
transition, and it takes the nodes down in reverse order before they are stopped.

Ctrl-C or SIGTERM: the manager deactivates and cleans up the nodes (the wall follower
publishes a zero velocity), then every node process gets SIGINT and, after GRACE_PERIOD,
SIGKILL; a second Ctrl-C skips the waiting. Exit status: 0 after a requested stop, 1 when
a node died or the startup failed (the message names the node), 2 for a bad bringup file.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Sequence

import rclpy
from rclpy.logging import LoggingSeverity
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions

from amr_bringup.bag_writer import bag_directory
from amr_bringup.lifecycle_manager import LifecycleManager
from amr_bringup.processes import NodeProcess, executable_path, stop_processes
from amr_bringup.recording import CATCH_UP_TIMEOUT, RecorderProcess, wait_until_matched
from amr_bringup.stack_config import (
    Bringup,
    BringupError,
    NodeSpec,
    check_installed,
    load_bringup,
    parse_assignments,
    shipped_stacks,
)
from amr_bringup.status import StatusMonitor, format_table
from amr_bringup.viewing import DEFAULT_HOST, DEFAULT_PORT, ViewerProcess, port_problem
from amr_util.executors import NodeSpinners
from amr_util.stop_signals import Flag, StopSignals

GRACE_PERIOD = 5.0
"""s a node gets to exit after SIGINT (or a clean shutdown takes) before SIGKILL."""
STATUS_PERIOD = 1.0
"""s between two status tables."""
RECENT_LINES = 12
"""Log lines kept under the live status table on a terminal."""
NODE_CLASSES: dict[tuple[str, str], tuple[str, str]] = {
    ("amr_simulation", "simulator"): ("amr_simulation.simulator_node", "SimulatorNode"),
    ("amr_control", "wall_follower"): ("amr_control.wall_follower_node", "WallFollowerNode"),
    ("amr_turtlebot3", "odometry_node"): ("amr_turtlebot3.odometry_node", "OdometryNode"),
    ("amr_kinematics", "ik_service"): ("amr_kinematics.ik_service_node", "IKServiceNode"),
    ("amr_localization", "particle_filter"): ("amr_localization.particle_filter_node", "ParticleFilterNode"),
    ("amr_localization", "beacon_localizer"): ("amr_localization.beacon_localizer_node", "BeaconLocalizerNode"),
    ("amr_maps", "map_server"): ("amr_maps.map_server_node", "MapServerNode"),
    ("amr_planning", "planner"): ("amr_planning.planner_node", "PlannerNode"),
    ("amr_control", "path_follower"): ("amr_control.path_follower_node", "PathFollowerNode"),
    ("amr_navigation", "navigator"): ("amr_navigation.navigator_node", "NavigatorNode"),
    ("amr_navigation", "fleet_planner"): ("amr_navigation.fleet_planner_node", "FleetPlannerNode"),
    ("amr_mapping", "slam"): ("amr_mapping.slam_node", "SlamNode"),
    ("amr_mapping", "explorer"): ("amr_mapping.explorer_node", "ExplorerNode"),
}
"""(package, executable) -> (module, class) of the nodes --composed can host."""


class Console:
    """All output, one line at a time from any thread; with --status on a terminal, a redrawn screen."""

    def __init__(self, live: bool) -> None:
        self.live = live
        self._lock = threading.Lock()
        self._recent: deque[str] = deque(maxlen=RECENT_LINES)

    def line(self, text: str) -> None:
        with self._lock:
            if self.live:
                self._recent.append(text)
            else:
                print(text, flush=True)

    def note(self, text: str) -> None:
        self.line(f"[amr-bringup] {text}")

    def table(self, text: str) -> None:
        with self._lock:
            if self.live:
                recent = "\n".join(self._recent)
                sys.stdout.write(f"\033[H\033[J{text}\n\n{recent}\n")
                sys.stdout.flush()
            else:
                print(text + "\n", flush=True)

    def end_live(self) -> None:
        with self._lock:
            self.live = False


class StackError(RuntimeError):
    """The stack could not be started; the message names the node."""


class ProcessStack:
    """One process per node."""

    def __init__(self, bringup: Bringup, console: Console) -> None:
        self.processes: list[NodeProcess] = []
        for node in bringup.nodes:
            command = [str(executable_path(node.package, node.executable)), *node.ros_arguments()]
            try:
                self.processes.append(NodeProcess(node.managed_name.lstrip("/"), command, console.line))
            except OSError as error:
                self.stop(Flag())
                raise StackError(f"node {node.managed_name} failed to start: {error}") from error
            console.note(f"started {node.managed_name} (pid {self.processes[-1].pid}): {' '.join(command)}")

    def failure(self) -> str | None:
        for process in self.processes:
            code = process.exit_code()
            if code is not None:
                return f"node {process.label} (pid {process.pid}) exited with code {code}"
        return None

    def stop(self, hurry: Flag) -> list[str]:
        return stop_processes(list(reversed(self.processes)), GRACE_PERIOD, hurry)


class ComposedStack:
    """Every node in this process, each spun on a thread of its own by the supervisor."""

    def __init__(self, bringup: Bringup, console: Console) -> None:
        self.nodes = []
        self.crash: str | None = None
        for node in bringup.nodes:
            try:
                self.nodes.append(node_class(node)(cli_args=node.ros_arguments()))
            except Exception as error:
                self.stop(Flag())
                raise StackError(
                    f"node {node.managed_name} failed to start: {type(error).__name__}: {error}"
                ) from error
            console.note(
                f"created {node.managed_name} ({type(self.nodes[-1]).__name__}) with {' '.join(node.ros_arguments())}"
            )

    def failure(self) -> str | None:
        return self.crash

    def record_crash(self, error: BaseException) -> None:
        """An exception out of the executor: name the innermost node of ours its traceback went through."""
        owners = [frame.f_locals.get("self") for frame, _ in traceback.walk_tb(error.__traceback__)]
        names = [owner.get_name() for owner in owners if any(owner is node for node in self.nodes)]
        where = f"node {names[-1]}" if names else "a callback"
        self.crash = f"{where} raised {type(error).__name__}: {error}"

    def stop(self, hurry: Flag) -> list[str]:
        for node in reversed(self.nodes):
            shut_down = getattr(node, "shut_down_cleanly", None)
            if shut_down is not None:
                shut_down()
            node.destroy_node()
        self.nodes = []
        return []


def node_class(node: NodeSpec) -> type:
    module, name = NODE_CLASSES[(node.package, node.executable)]
    return getattr(importlib.import_module(module), name)


def check_composable(bringup: Bringup) -> None:
    for i, node in enumerate(bringup.nodes):
        if (node.package, node.executable) not in NODE_CLASSES:
            known = ", ".join(f"{p}/{e}" for p, e in NODE_CLASSES)
            raise BringupError(
                f"{bringup.source}: nodes[{i}].executable: {node.package}/{node.executable} "
                f"has no node class for --composed (known: {known})"
            )


class Supervisor:
    """Runs the lifecycle manager (and the status monitor) over a started stack until a stop or a failure."""

    def __init__(self, bringup: Bringup, options: argparse.Namespace, console: Console, signals: StopSignals) -> None:
        self.bringup, self.options, self.console, self.signals = bringup, options, console, signals
        self.started_at = time.monotonic()
        self.spinners = NodeSpinners(on_error=self._on_callback_error)
        self.stack: ProcessStack | ComposedStack | None = None
        self.manager: LifecycleManager | None = None
        self.monitor: StatusMonitor | None = None
        self.recorder: RecorderProcess | None = None
        self.recorder_client: Node | None = None
        self.viewer: ViewerProcess | None = None
        self.active = False
        self.active_since = self.started_at
        self._startup_steps: list = []
        self._startup = threading.Thread(target=lambda: self._startup_steps.extend(self.manager.startup()), daemon=True)

    def run(self, make_stack: Callable[[Bringup, Console], ProcessStack | ComposedStack]) -> int:
        """Start, watch, take down; whatever happens, nothing this started is left running."""
        failure = None
        try:
            self.stack = make_stack(self.bringup, self.console)
            self._add_nodes()
            self._startup.start()
            failure = self._watch()
            self.console.end_live()
            self.console.note(f"stopping: {failure}" if failure else "stopping")
            if not failure:  # also mid-startup: the manager cancels it and takes down what is up
                self._shut_down_managed_nodes()
        except StackError as error:
            failure = str(error)
        finally:
            self.console.end_live()
            killed = self._take_down()
        if killed and not self.signals.hurry.is_set():
            failure = failure or f"node(s) {', '.join(killed)} did not exit within {GRACE_PERIOD} s of SIGINT (killed)"
        if failure:
            print(f"amr-bringup: {failure}", file=sys.stderr, flush=True)
            return 1
        self.console.note("stopped")
        return 0

    def _add_nodes(self) -> None:
        for node in getattr(self.stack, "nodes", []):
            self.spinners.add_node(node)
        if self.options.record:
            self._add_recorder()
        if self.options.view:
            self._add_viewer()
        self.manager = LifecycleManager(
            before_activate=self._before_activate,
            cli_args=["--ros-args", "-r", f"__node:={self.bringup.manager_name}"],
            parameter_overrides=[Parameter(k, value=v) for k, v in self.bringup.manager_parameters().items()],
        )
        if self.console.live:
            self.manager.get_logger().set_level(LoggingSeverity.WARN)
        self.spinners.add_node(self.manager)
        if self.options.status:
            self.monitor = StatusMonitor(
                self.bringup.node_startup_order, [(node.name, node.namespace) for node in self.bringup.nodes]
            )
            self.spinners.add_node(self.monitor)

    def _before_activate(self, name: str) -> None:
        """With --record: wait until the recorder listens to the node's topics (and, composed, they to it)."""
        if self.recorder is None or not self.recorder.wait_until_caught_up():
            return
        for node in getattr(self.stack, "nodes", []):
            if node.get_fully_qualified_name().lstrip("/") == name.lstrip("/"):
                unmatched = wait_until_matched(node, self.options.topics or [])
                if unmatched:
                    self.console.note(
                        f"{name}: {' '.join(unmatched)} not matched with every subscriber within "
                        f"{CATCH_UP_TIMEOUT} s; the bag may miss their first messages"
                    )

    def _add_recorder(self) -> None:
        """The recorder runs as a process of its own (amr_bringup.recording); each node is activated once it
        listens to that node's topics, so a lockstep run's first observation is in the bag too."""
        simulated = any(node.parameters.get("use_sim_time") is True for node in self.bringup.nodes)
        self.recorder_client = Node(f"{self.bringup.manager_name}_recorder_client")
        self.spinners.add_node(self.recorder_client)
        try:
            self.recorder = RecorderProcess(
                f"recorder_{self.bringup.name}",
                str(self.options.record),
                self.options.topics or [],
                simulated,
                self.recorder_client,
                self.console.line,
            )
        except OSError as error:
            raise StackError(f"--record: the recorder failed to start: {error}") from error
        self.console.note(
            f"recording {' '.join(self.options.topics) if self.options.topics else 'every topic'} "
            f"to {bag_directory(self.options.record)}"
            + (" (stamps on /clock)" if simulated else "")
            + f": {' '.join(self.recorder.command)}"
        )

    def _add_viewer(self) -> None:
        """The viewer (amr_viewer) as a process of its own, on simulated time with a simulated stack."""
        simulated = any(node.parameters.get("use_sim_time") is True for node in self.bringup.nodes)
        try:
            self.viewer = ViewerProcess(
                f"viewer_{self.bringup.name}",
                self.options.view_host,
                self.options.view_port,
                simulated,
                self.console.line,
            )
        except OSError as error:
            raise StackError(f"--view: the viewer failed to start: {error}") from error
        self.console.note(
            f"viewer at {self.viewer.url} (no authentication: anyone who can reach it can drive the "
            f"robot): {' '.join(self.viewer.command)}"
        )

    def _on_callback_error(self, error: BaseException) -> None:
        if isinstance(self.stack, ComposedStack):  # a callback raised: the composed stack is broken
            self.stack.record_crash(error)

    def _watch(self) -> str | None:
        """Wait for a stop request, the end of --duration or a failure (returned, naming the node)."""
        next_table = time.monotonic()
        while not self.signals.stop.wait(0.1):
            failure = self.stack.failure()
            if failure:
                return failure
            if self.recorder is not None and self.recorder.process.exit_code() is not None:
                return (
                    f"the recorder (pid {self.recorder.process.pid}) exited with code "
                    f"{self.recorder.process.exit_code()}"
                )
            if self.viewer is not None and not self.viewer.reported and self.viewer.process.exit_code() is not None:
                self.viewer.reported = True  # the stack goes on without its view
                self.console.note(
                    f"the viewer (pid {self.viewer.process.pid}) exited with code "
                    f"{self.viewer.process.exit_code()}; the stack goes on"
                )
            if not self._startup.is_alive() and not self.active:
                if not self.manager.started:
                    last = self._startup_steps[-1] if self._startup_steps else None
                    return (
                        f"startup failed at {last.transition} of {last.node}: {last.detail}"
                        if last
                        else "startup failed"
                    )
                self.active = True
                self.active_since = time.monotonic()
                self.console.note(f"all nodes active: {', '.join(self.bringup.node_startup_order)}")
            if self.monitor is not None and time.monotonic() >= next_table:
                next_table += STATUS_PERIOD
                self._print_status()
            if (
                self.active
                and self.options.duration is not None
                and time.monotonic() - self.active_since >= self.options.duration
            ):
                return None
        return None

    def _print_status(self) -> None:
        self.monitor.refresh()
        states, rows = self.monitor.snapshot()
        title = f"amr-bringup {self.bringup.name}  {time.monotonic() - self.started_at:.0f} s"
        self.console.table(format_table(title, states, rows))

    def _shut_down_managed_nodes(self) -> None:
        """The manager deactivates and cleans up in reverse order, for GRACE_PERIOD at most."""
        shutdown = threading.Thread(target=self.manager.shutdown, daemon=True)
        shutdown.start()
        deadline = time.monotonic() + GRACE_PERIOD
        while shutdown.is_alive() and time.monotonic() < deadline and not self.signals.hurry.is_set():
            shutdown.join(0.05)

    def _take_down(self) -> list[str]:
        """Stop spinning, stop the stack (the labels of killed processes are returned), free ROS."""
        self.spinners.shutdown(timeout_sec=GRACE_PERIOD)  # no callback runs while the nodes are taken down
        killed = self.stack.stop(self.signals.hurry) if self.stack is not None else []
        if self.viewer is not None:
            killed += stop_processes([self.viewer.process], GRACE_PERIOD, self.signals.hurry)
        if self.recorder is not None:  # last: the bag holds everything the nodes said on their way down
            killed += stop_processes([self.recorder.process], GRACE_PERIOD, self.signals.hurry)
            self.recorder.process.close()
            self.console.note(f"recorded to {bag_directory(self.options.record)}")
        for node in (self.manager, self.monitor, self.recorder_client):
            if node is not None:
                node.destroy_node()
        rclpy.try_shutdown()
        return killed


def format_arguments(bringup: Bringup) -> str:
    """The stack's arguments as `ros2 launch --show-args` lists them, with what they are now."""
    lines = ["Arguments (pass arguments as '<name>:=<value>'):"]
    for name, argument in bringup.arguments.items():
        targets = (
            ", ".join(f"{node}.{parameter}" for node, parameter in argument.sets)
            or f"the parameter files of {argument.params_file_of}"
        )
        lines += [
            f"    '{name}':",
            f"        {argument.description} (sets {targets})",
            f"        (now: {bringup.current_value(name)!r})",
        ]
    return "\n".join(lines)


def parse_arguments(argv: Sequence[str] | None) -> argparse.Namespace:
    stacks = shipped_stacks()
    width = max(map(len, stacks), default=0)
    parser = argparse.ArgumentParser(
        prog="amr-bringup",
        description="Start a stack of lifecycle nodes from a bringup file and keep it up.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="shipped stacks (config/bringup/<name>.yaml):\n"
        + "\n".join(f"  {name:<{width}}  {summary}" for name, summary in stacks.items())
        if stacks
        else None,
    )
    parser.add_argument("bringup", help="a bringup YAML file, or the name of a shipped stack (listed below)")
    parser.add_argument(
        "arguments",
        nargs="*",
        metavar="name:=value",
        help="the stack's arguments (see --show-args), e.g. world:=hard_maze.yaml",
    )
    parser.add_argument(
        "-p",
        dest="parameters",
        action="append",
        default=[],
        metavar="NODE.PARAMETER:=VALUE",
        help="a parameter of one node, after its files, e.g. -p wall_follower.kp:=3.0",
    )
    parser.add_argument("--show-args", action="store_true", help="list the stack's arguments and exit")
    parser.add_argument(
        "--composed", action="store_true", help="all nodes in this process (a thread each) instead of one process each"
    )
    parser.add_argument(
        "--status",
        action="store_true",
        help="print a table of the nodes' lifecycle states and the topic rates every second",
    )
    parser.add_argument(
        "--duration",
        type=float,
        metavar="S",
        help="stop cleanly after S seconds with every node active (a startup is bounded by the "
        "manager's wait_timeout and transition_timeout, not by S)",
    )
    parser.add_argument(
        "--record",
        metavar="BAG",
        help="record a rosbag2 MCAP bag: out/run.mcap writes the directory out/run (every topic, or --topics)",
    )
    parser.add_argument("--topics", nargs="+", metavar="TOPIC", help="with --record: only these topics")
    parser.add_argument(
        "--view",
        action="store_true",
        help="watch and steer the stack in a browser (amr_viewer, a process of its own); prints its "
        "address. There is no authentication: keep --view-host on localhost unless you trust "
        "your network",
    )
    parser.add_argument(
        "--view-port",
        type=int,
        default=DEFAULT_PORT,
        metavar="PORT",
        help=f"with --view: the port of the viewer's web server (default {DEFAULT_PORT})",
    )
    parser.add_argument(
        "--view-host",
        default=DEFAULT_HOST,
        metavar="ADDRESS",
        help=f"with --view: the address it binds (default {DEFAULT_HOST}, this machine only; "
        "0.0.0.0 for every interface)",
    )
    options = parser.parse_args(argv)
    if options.duration is not None and not options.duration > 0:
        parser.error("--duration must be positive")
    if options.topics and not options.record:
        parser.error("--topics needs --record")
    if options.record and bag_directory(options.record).exists():
        parser.error(f"--record: {bag_directory(options.record)} exists already; a recording never overwrites a bag")
    if not options.view and (options.view_port != DEFAULT_PORT or options.view_host != DEFAULT_HOST):
        parser.error("--view-port and --view-host need --view")
    if options.view and not 1 <= options.view_port <= 65535:
        parser.error(f"--view-port must be in 1..65535, got {options.view_port}")
    return options


def main(argv: Sequence[str] | None = None) -> int:
    options = parse_arguments(argv)
    if options.view and not options.show_args:  # here, not in the parser: parsing binds nothing
        problem = port_problem(options.view_host, options.view_port)
        if problem:
            print(f"amr-bringup: --view: {problem} (choose another with --view-port)", file=sys.stderr)
            return 2
    try:
        bringup = load_bringup(options.bringup)
        if options.show_args:
            print(format_arguments(bringup))
            return 0
        bringup = bringup.with_overrides(
            parse_assignments(options.arguments, "argument"), parse_assignments(options.parameters, "-p")
        )
        check_installed(bringup, executables=not options.composed)
        if options.composed:
            check_composable(bringup)
    except BringupError as error:
        print(f"amr-bringup: {error}", file=sys.stderr)
        return 2
    signals = StopSignals()
    console = Console(live=options.status and sys.stdout.isatty())
    rclpy.init(args=[], signal_handler_options=SignalHandlerOptions.NO)
    return Supervisor(bringup, options, console, signals).run(ComposedStack if options.composed else ProcessStack)


if __name__ == "__main__":
    raise SystemExit(main())
