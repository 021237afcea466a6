"""ik_service: /solve_ik and /compute_fk for the arm chains declared in its parameters.

A thin lifecycle shell over ``amr_kinematics.config`` (chains, defaults, solvers):

- construction declares ``chains`` and each ``<chain>.<key>`` given to the node (keys in
  ``amr_kinematics/config.py``), each typed and described (``amr_kinematics.parameters``);
  an unknown key or a bad value fails configure, naming every one.  Geometry is
  structural (refused while configured); solve defaults and the service caps are live
  (the chain set is validated again and used from the next request).  Without a
  ``chains`` parameter it declares the packaged ``config/ik_chains.yaml`` instead,
  so ``ros2 run amr_kinematics ik_service`` serves the shipped arms.
- configure loads and validates every chain, all or nothing (a bad chain fails the
  transition with a log naming chain and key; the node stays unconfigured), then
  creates ``/solve_ik``, ``/compute_fk`` and ``~/joint_states``.
- the services exist from configure on and refuse requests (success=false, message
  "inactive") until activation, so a client sees why nothing is solved.
- cleanup (and shutdown) destroys them and forgets the chains and last solutions.

Every reply carries a message; no exception leaves a callback.  Services are in a
reentrant callback group (run with a MultiThreadedExecutor): requests on different
chains run side by side; requests on one chain take turns (a per-chain lock), and a
request's timeout covers both its wait for the chain and its solve.  Side by side,
not in parallel: solves are pure Python and share the GIL (see GIL_SWITCH_INTERVAL).
"""

from __future__ import annotations

import math
import sys
import threading
import time
from array import array

import numpy as np
from geometry_msgs.msg import Point, Pose
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.lifecycle import State, TransitionCallbackReturn
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from amr_interfaces.srv import ComputeFK, SolveIK
from amr_kinematics.config import CHAIN_KEYS, NODE_NAME, ChainConfig, flatten_parameters, load_chain_set
from amr_kinematics.errors import KinematicsError
from amr_kinematics.parameters import chain_specs
from amr_kinematics.solvers.task import parse_task
from amr_kinematics.transforms import matrix_quaternion, pose_matrix
from amr_util.managed_node import ManagedNode, run
from amr_util.parameter_file import node_parameters
from amr_util.share import share_directory

PACKAGE = "amr_kinematics"
DEFAULT_CONFIG = "config/ik_chains.yaml"  # in the package's share directory
QUATERNION_TOLERANCE = 1e-3  # |q| may differ from 1 by this much (then it is normalised)
MAX_MESSAGE = 400  # characters of a reply message: a request's megabyte name is not echoed back
LOG_THROTTLE = 5.0  # s between repeated error logs of a callback
# s; Python's default is 5 ms.  A solve is pure Python and holds the GIL; the executor and
# the other callbacks give it up at every rclpy or numpy call and wait for it again.  With
# 5 ms, a request on another chain took 0.3-1.8 s while a 2 s solve ran; with 0.2 ms,
# 9 ms (median), and the bench's latency and throughput did not change.
GIL_SWITCH_INTERVAL = 0.0002
# Deeper than the default services profile (10): requests that arrive while every
# executor thread is busy queue here, and the 11th onwards would be dropped unanswered.
SERVICE_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)


def _bounded(text: str, limit: int = MAX_MESSAGE) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def pose_from_matrix(matrix: np.ndarray) -> Pose:
    """geometry_msgs/Pose of a 4x4 transform (quaternion with w >= 0)."""
    x, y, z, w = matrix_quaternion(matrix[:3, :3])  # closed form: transforms3d's eigh-based mat2quat costs 45 us
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in matrix[:3, 3])
    pose.orientation.w, pose.orientation.x = float(w), float(x)
    pose.orientation.y, pose.orientation.z = float(y), float(z)
    return pose


def target_from_pose(pose: Pose, planar: bool, with_orientation: bool):
    """The library's target for a request pose, or a refusal message (str).

    Position only: (x, y) for planar chains, (x, y, z) otherwise; with orientation a
    4x4 pose (the library keeps only the yaw of a planar chain's target).
    """
    p, o = pose.position, pose.orientation
    values = (p.x, p.y, p.z, o.x, o.y, o.z, o.w)
    if not all(map(math.isfinite, values)):
        return "target must be finite: NaN or inf in target.position or target.orientation"
    if not with_orientation:
        return (p.x, p.y) if planar else (p.x, p.y, p.z)
    norm = math.sqrt(o.w * o.w + o.x * o.x + o.y * o.y + o.z * o.z)
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        return f"target.orientation must be a unit quaternion (|q| = {norm:.6g})"
    return pose_matrix((p.x, p.y, p.z), (o.x, o.y, o.z, o.w))


def _plain(value):
    """A parameter value as the library takes it: arrays as lists."""
    return value.tolist() if isinstance(value, array) else value


def packaged_chain_parameters() -> dict:
    """{name: value} of the packaged config/ik_chains.yaml, {} if it is not installed."""
    path = share_directory(PACKAGE) / DEFAULT_CONFIG
    if not path.is_file():
        return {}
    return flatten_parameters(node_parameters(path, NODE_NAME))


class IKServiceNode(ManagedNode):
    """Serves IK and FK for the chains of its parameters (see the module docstring)."""

    multithreaded_executor = True  # requests for different chains are served at once

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self._declare_chain_parameters()
        self._group = ReentrantCallbackGroup()
        self._chains: dict[str, ChainConfig] = {}
        self._chain_locks: dict[str, threading.Lock] = {}
        self._last: dict[str, np.ndarray] = {}  # last successful solution per chain
        self._last_lock = threading.Lock()
        self._active = False
        self._max_timeout = self._max_iterations = None  # from the parameters at configure
        self._node_services = []
        self._joint_states = None

    def _declare_chain_parameters(self) -> None:
        """Declare ``chains`` and every ``<chain>.<key>`` given (or the packaged set), each typed.

        rclpy has no public accessor for the overrides of a node; ``_parameter_overrides``
        is what ``automatically_declare_parameters_from_overrides`` itself reads.
        """
        given = {name: _plain(parameter.value) for name, parameter in self._parameter_overrides.items()}
        if "chains" not in given:
            packaged = packaged_chain_parameters()
            if packaged:
                self.get_logger().info(f"no 'chains' parameter: serving the packaged {DEFAULT_CONFIG}")
            given = {**packaged, **given}
        self.declare_specs(chain_specs(given))

    # --- lifecycle ------------------------------------------------------------------------
    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if problems:
            return self.fail_configure(problems)
        values = self.parameter_values()
        try:
            chains = load_chain_set(values)
        except ValueError as exc:  # ChainConfigError names chain and key
            self.get_logger().error(f"configure failed, nothing loaded: {exc}")
            return TransitionCallbackReturn.FAILURE
        self._max_timeout, self._max_iterations = values["max_timeout"], values["max_iterations_limit"]
        for config in chains.values():  # the first request must not pay first-call costs
            config.warm_up()
        self._chains = chains
        self._chain_locks = {name: threading.Lock() for name in chains}
        with self._last_lock:
            self._last = {}
        self._joint_states = self.create_lifecycle_publisher(JointState, "~/joint_states", 10)
        self._node_services = [
            self.create_service(
                SolveIK, "/solve_ik", self._on_solve_ik, qos_profile=SERVICE_QOS, callback_group=self._group
            ),
            self.create_service(
                ComputeFK, "/compute_fk", self._on_compute_fk, qos_profile=SERVICE_QOS, callback_group=self._group
            ),
        ]
        summary = ", ".join(f"{name} ({c.chain.n} joints, {c.solver})" for name, c in chains.items())
        self.get_logger().info(f"chains: {summary}")
        return TransitionCallbackReturn.SUCCESS

    def known_parameters(self, unknown: str) -> list[str]:
        """Every key a chain may have, for a typo in one of its keys."""
        chain, dot, _ = unknown.partition(".")
        return [f"{chain}.{key}" for key in sorted(CHAIN_KEYS)] if dot else super().known_parameters(unknown)

    def apply_live(self, changes: dict) -> None:
        """New solve defaults or caps: the whole chain set is validated, then used from the next request."""
        values = {**self.parameter_values(), **changes}
        chains = load_chain_set(values)
        self._chains = chains
        self._max_timeout, self._max_iterations = values["max_timeout"], values["max_iterations_limit"]

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._active = True
        self.get_logger().info("serving /solve_ik and /compute_fk")
        return super().on_activate(state)

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._active = False
        self.get_logger().info("inactive: requests are refused")
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._release()
        return super().on_cleanup(state)  # and whatever else configure made

    def _release(self) -> None:
        """Services and publisher destroyed, chains and last solutions forgotten."""
        for service in self._node_services:
            self.destroy_service(service)
        if self._joint_states is not None:
            self.destroy_lifecycle_publisher(self._joint_states)
        self._node_services, self._joint_states = [], None
        self._chains, self._chain_locks = {}, {}
        with self._last_lock:
            self._last = {}

    # --- services -------------------------------------------------------------------------
    def _answer(self, service: str, work, request, response):
        """work(request, response), with every message bounded; a bug costs one request, not the node."""
        try:
            work(request, response)
        except Exception as exc:
            self.get_logger().error(f"{service} failed: {exc!r}", throttle_duration_sec=LOG_THROTTLE)
            response = type(response)(success=False, message=f"internal error: {type(exc).__name__}: {exc}")
        response.message = _bounded(response.message)
        return response

    def _on_solve_ik(self, request: SolveIK.Request, response: SolveIK.Response) -> SolveIK.Response:
        return self._answer("/solve_ik", self._solve, request, response)

    def _solve(self, request: SolveIK.Request, response: SolveIK.Response) -> None:
        config = self._serving_chain(request.chain, response)
        if config is None:
            return
        chain = config.chain
        response.solver = _bounded(request.solver, 40) or config.solver
        if request.seed and len(request.seed) != chain.n:
            response.message = f"seed has {len(request.seed)} values; chain '{chain.name}' has {chain.n} joints"
            return
        limits = self._limits(request, config, response)
        if limits is None:
            return
        timeout, max_iterations, note = limits
        try:
            task = parse_task(list(request.task_weights), list(request.pointing))
        except KinematicsError as exc:
            response.message = str(exc)
            return
        # a task takes the orientation only when its rotation weights ask for it
        with_orientation = task.uses_rotation_target if task is not None else request.with_orientation
        target = target_from_pose(request.target, chain.planar, with_orientation)
        if isinstance(target, str):
            response.message = target
            return
        lock = self._chain_locks[chain.name]
        if not lock.acquire(blocking=False):  # another solve on this chain: the wait counts against the timeout
            waiting_since = time.monotonic()
            busy = f"chain '{chain.name}' stayed busy with other solves for the whole timeout ({timeout} s)"
            if not lock.acquire(timeout=timeout):
                response.message = busy
                return
            timeout -= time.monotonic() - waiting_since
            if timeout <= 0.0:
                lock.release()
                response.message = busy
                return
        try:
            seed = list(request.seed) if request.seed else self._last_solution(chain.name)
            result = config.solve(
                target,
                solver=request.solver,
                seed=seed,
                with_orientation=request.with_orientation,
                tolerance=request.tolerance,
                max_iterations=max_iterations,
                timeout=timeout,
                task=task,
            )
            if result.success:
                with self._last_lock:
                    self._last[chain.name] = result.q
        except KinematicsError as exc:
            response.message = str(exc)
            return
        finally:
            lock.release()
        response.success = result.success
        response.positions = result.q.tolist()
        response.reached = pose_from_matrix(result.reached)
        response.position_error = result.position_error
        response.orientation_error = result.orientation_error
        response.iterations = result.iterations
        response.solver = result.solver
        response.message = result.message + note
        if result.success:
            self._publish(chain.name, response.joint_names, response.positions)

    def _limits(self, request: SolveIK.Request, config: ChainConfig, response) -> tuple[float, int, str] | None:
        """(timeout, max_iterations, note) after defaults and caps; None (message set) if refused."""
        for name in ("tolerance", "timeout"):
            value = getattr(request, name)
            if not (math.isfinite(value) and value >= 0.0):
                response.message = f"{name} must be a finite number >= 0 (0 = the chain's default), got {value}"
                return None
        timeout = request.timeout or config.timeout
        max_iterations = request.max_iterations or config.max_iterations
        notes = []
        if timeout > self._max_timeout:
            timeout = self._max_timeout
            notes.append(f"timeout capped at {timeout} s")
        if max_iterations > self._max_iterations:
            max_iterations = self._max_iterations
            notes.append(f"max_iterations capped at {max_iterations}")
        return timeout, max_iterations, f" ({'; '.join(notes)})" if notes else ""

    def _last_solution(self, chain: str) -> np.ndarray | None:
        with self._last_lock:
            return self._last.get(chain)

    def _publish(self, chain: str, joint_names: list[str], positions: list[float]) -> None:
        publisher = self._joint_states
        if publisher is None:
            return
        message = JointState()
        message.header.stamp = self.get_clock().now().to_msg()
        message.header.frame_id = f"{chain}/base"
        message.name = [f"{chain}/{joint}" for joint in joint_names]
        message.position = positions
        publisher.publish(message)

    def _on_compute_fk(self, request: ComputeFK.Request, response: ComputeFK.Response) -> ComputeFK.Response:
        return self._answer("/compute_fk", self._forward, request, response)

    def _forward(self, request: ComputeFK.Request, response: ComputeFK.Response) -> None:
        config = self._serving_chain(request.chain, response)
        if config is None:
            return
        chain = config.chain
        if len(request.positions) != chain.n:
            response.message = (
                f"positions has {len(request.positions)} values; chain '{chain.name}' has {chain.n} joints"
            )
            return
        try:
            fk = chain.fk(list(request.positions))
        except KinematicsError as exc:
            response.message = str(exc)
            return
        response.tool_pose = pose_from_matrix(fk.tool)
        response.joint_origins = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in fk.frames[:, :3, 3]]
        response.success = True
        q = np.asarray(request.positions)
        outside = [
            name
            for name, value, low, high in zip(chain.joint_names, q, chain.lower, chain.upper, strict=True)
            if not low <= value <= high
        ]
        response.message = "ok" + (f" (outside the joint limits: {', '.join(outside)})" if outside else "")

    def _serving_chain(self, name: str, response) -> ChainConfig | None:
        """The chain a request names (its joint names set in the response, success still false),
        or None with the refusal in response.message."""
        response.success = False
        if not self._active:
            response.message = f"{NODE_NAME} is {self.state_label}: activate it to serve requests"
            return None
        chains = self._chains
        config = chains.get(name)
        if config is None:
            response.message = f"unknown chain {_bounded(name, 40)!r}; known: {', '.join(chains)}"
        else:
            response.joint_names = list(config.chain.joint_names)
        return config


def main(args=None) -> None:
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    run(IKServiceNode, args=args)


if __name__ == "__main__":
    main()
