"""``amr/Maze-v0``: a Gymnasium environment over the simulator library (no ROS), for learning-based controllers.

    import gymnasium
    import amr_evaluation.gym_env  # registers amr/Maze-v0 (or: gymnasium.make("amr_evaluation.gym_env:amr/Maze-v0"))
    env = gymnasium.make("amr/Maze-v0", families=["perfect", "bends"], max_steps=2000)
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Gymnasium 1.x no longer loads the ``gymnasium.envs`` entry-point group at import (checked on 1.4.0:
``gymnasium/envs/__init__.py`` registers only its own environments), so the id is registered when this
module is imported; ``gymnasium.make("amr_evaluation.gym_env:amr/Maze-v0")`` imports it by itself. The
package still declares that entry point (``register_envs``) for tools that read it.

Observation (``Box`` float32, every value finite): the LiDAR ranges divided by ``range_max``, clipped to
[0, 1] (no return, REP 117's +inf, reads 1; a return closer than ``range_min``, -inf, reads 0), every
``scan_stride``-th beam of the 240; the encoder odometry's twist, v / max_linear and w / max_angular,
clipped to [-1, 1]; the goal in the robot frame, (x, y) / ``goal_scale`` clipped to [-1, 1].

Action: ``Box(-1, 1, (2,))``, scaled to the Burger's limits (v = a0 * 0.22 m/s, w = a1 * 2.84 rad/s; the
simulator saturates the wheels keeping the curvature, as the robot does). One step is one ``dt`` (0.05 s).

Reward: ``progress_weight`` x the metres gained toward the goal (straight-line distance), minus
``time_penalty`` each step; ``goal_reward`` on reaching the goal region, minus ``collision_penalty`` on a
new wall contact. Terminated at the goal or on a contact (``terminate_on_collision``); truncated after
``max_steps`` steps.

World: ``world`` fixed (a shipped name, a path, or a world spec of amr_evaluation.worlds), or drawn at each
``reset(seed=...)`` from ``families`` (default: all of amr_maps.maze_families) with a maze seed
from the environment's generator, so the same seed gives the same world, start, noise and episode. A
world without a goal gets its farthest free point as one.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import gymnasium
import numpy as np
from gymnasium import spaces

from amr_util.scan import ScanData
from amr_evaluation.worlds import build_world, with_goal, world_spec_of_file
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
from amr_maps.maze_families import FAMILIES
from amr_simulation.simulator import Simulator

ENV_ID = "amr/Maze-v0"


class MazeEnv(gymnasium.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, world: str | dict | None = None, families: Sequence[str] | None = None,
                 maze_options: dict | None = None, max_steps: int = 2000, scan_stride: int = 1,
                 lidar_noise: float = 0.01, encoder_noise: float = 0.0, slip: float = 0.0,
                 progress_weight: float = 10.0, time_penalty: float = 0.01, goal_reward: float = 10.0,
                 collision_penalty: float = 10.0, terminate_on_collision: bool = True, goal_scale: float = 10.0,
                 render_mode: str | None = None) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode {render_mode!r}: expected one of {self.metadata['render_modes']}")
        if world is not None and families is not None:
            raise ValueError("give a fixed world or families to draw from, not both")
        if max_steps < 1 or scan_stride < 1 or goal_scale <= 0:
            raise ValueError(f"max_steps and scan_stride must be >= 1 and goal_scale > 0, got {max_steps}, "
                             f"{scan_stride}, {goal_scale}")
        self.world_spec = world_spec_of_file(world) if isinstance(world, str) else world
        self.families = None if world is not None else tuple(families or FAMILIES)
        unknown = [f for f in self.families or () if f not in FAMILIES]
        if unknown:
            raise ValueError(f"families: unknown {unknown[0]!r} (known: {', '.join(FAMILIES)})")
        self.maze_options = dict(maze_options or {})
        self.max_steps = int(max_steps)
        self.config = SimulationConfig(lidar=LidarConfig(noise_std=lidar_noise),
                                       encoders=EncoderConfig(noise=encoder_noise, slip=slip))
        self.robot = self.config.robot
        self.lidar = self.config.lidar
        self.scan_stride = int(scan_stride)
        self.beam_indices = np.arange(0, self.lidar.beams, self.scan_stride)
        self.progress_weight, self.time_penalty = progress_weight, time_penalty
        self.goal_reward, self.collision_penalty = goal_reward, collision_penalty
        self.terminate_on_collision, self.goal_scale = terminate_on_collision, goal_scale
        self.render_mode = render_mode
        size = len(self.beam_indices) + 4
        low = np.concatenate([np.zeros(len(self.beam_indices)), -np.ones(4)]).astype(np.float32)
        self.observation_space = spaces.Box(low, np.ones(size, dtype=np.float32), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)
        self.sim: Simulator | None = None
        self.sim_seed: int | None = None
        self.world_name = ""
        self._fixed_world = build_world(self.world_spec) if self.world_spec is not None else None
        self._steps = 0
        self._distance = math.nan

    # -- the gymnasium API ------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        rng = self.np_random
        if self._fixed_world is not None:
            world = self._fixed_world
        else:
            family = self.families[int(rng.integers(len(self.families)))]
            spec = {"family": family, "seed": int(rng.integers(2**31 - 1)), "options": dict(self.maze_options)}
            world = build_world(spec)
        self.sim_seed = int(rng.integers(2**31 - 1))
        if world.goal is None:
            world = with_goal(world, "far", self.sim_seed)
        self.sim = Simulator(world, SimulationConfig(dt=self.config.dt, seed=self.sim_seed, robot=self.robot,
                                                     lidar=self.lidar, encoders=self.config.encoders))
        self.world_name = world.name
        self._steps = 0
        self._distance = self._goal_distance()
        return self._observation(), self._info()

    def step(self, action):
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        action = np.asarray(action, dtype=float).reshape(2)
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action {action.tolist()}: must be finite")
        action = np.clip(action, -1.0, 1.0)
        collisions = self.sim.collisions
        self.sim.step(float(action[0]) * self.robot.max_linear, float(action[1]) * self.robot.max_angular)
        self._steps += 1
        distance = self._goal_distance()
        reward = self.progress_weight * (self._distance - distance) - self.time_penalty
        self._distance = distance
        collided = self.sim.collisions > collisions
        reached = self.sim.goal_reached
        if reached:
            reward += self.goal_reward
        if collided:
            reward -= self.collision_penalty
        terminated = bool(reached or (collided and self.terminate_on_collision))
        truncated = bool(not terminated and self._steps >= self.max_steps)
        return self._observation(), float(reward), terminated, truncated, self._info(collided=collided)

    def render(self):
        if self.render_mode != "rgb_array" or self.sim is None:
            return None
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        figure = Figure(figsize=(4, 4), dpi=80)
        canvas = FigureCanvasAgg(figure)
        axes = figure.add_subplot()
        self.sim.draw(axes)
        axes.set_axis_off()
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()

    # -- helpers -------------------------------------------------------------------------------------

    def scan_of_observation(self, observation: np.ndarray) -> ScanData:
        """The LaserScan fields a controller reads, back from an observation (1 -> +inf, 0 -> -inf)."""
        normalized = np.asarray(observation[: len(self.beam_indices)], dtype=float)
        ranges = normalized * self.lidar.range_max
        ranges[normalized >= 1.0] = math.inf
        ranges[normalized <= 0.0] = -math.inf
        return ScanData(ranges, self.lidar.angle_min, self.lidar.angle_increment * self.scan_stride,
                        self.lidar.range_min, self.lidar.range_max)

    def twist_of_observation(self, observation: np.ndarray) -> tuple[float, float]:
        v, w = observation[len(self.beam_indices): len(self.beam_indices) + 2]
        return float(v) * self.robot.max_linear, float(w) * self.robot.max_angular

    def action_of_command(self, v: float, w: float) -> np.ndarray:
        """A (v, w) command in m/s and rad/s as this environment's normalized action."""
        return np.clip(np.array([v / self.robot.max_linear, w / self.robot.max_angular], dtype=np.float32), -1, 1)

    def _goal_distance(self) -> float:
        pose, goal = self.sim.pose, self.sim.goal
        return math.hypot(goal.x - pose.x, goal.y - pose.y)

    def _observation(self) -> np.ndarray:
        sim = self.sim
        beams = len(self.beam_indices)
        observation = np.empty(beams + 4, dtype=np.float32)
        scan = np.asarray(sim.ranges, dtype=float)[self.beam_indices] / self.lidar.range_max
        np.clip(scan, 0.0, 1.0, out=scan)  # +inf (no return) -> 1, -inf (closer than range_min) -> 0
        scan[np.isnan(scan)] = 1.0
        observation[:beams] = scan
        v, w = sim.odom_twist
        pose, goal = sim.pose, sim.goal
        dx, dy = goal.x - pose.x, goal.y - pose.y
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        for index, value in enumerate((v / self.robot.max_linear, w / self.robot.max_angular,
                                       (c * dx + s * dy) / self.goal_scale, (-s * dx + c * dy) / self.goal_scale)):
            observation[beams + index] = min(1.0, max(-1.0, value)) if math.isfinite(value) else 0.0
        return observation

    def _info(self, collided: bool = False) -> dict[str, Any]:
        sim = self.sim
        return {"world": self.world_name, "time": sim.time, "goal_distance": self._distance,
                "collisions": sim.collisions, "collided": collided, "goal_reached": sim.goal_reached,
                "sim_seed": self.sim_seed}


def register_envs() -> None:
    """Register amr/Maze-v0 with gymnasium (idempotent)."""
    if ENV_ID not in gymnasium.registry:
        gymnasium.register(id=ENV_ID, entry_point="amr_evaluation.gym_env:MazeEnv")


register_envs()
