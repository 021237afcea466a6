"""``amr/Maze-v0``: a Gymnasium environment over the simulator library (no ROS), for learning-based controllers.

    import gymnasium
    import amr_evaluation.gym_env  # registers amr/Maze-v0 (or: gymnasium.make("amr_evaluation.gym_env:amr/Maze-v0"))
    env = gymnasium.make("amr/Maze-v0", families=["perfect", "bends"], max_steps=2000)
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Gymnasium 1.x no longer loads the ``gymnasium.envs`` entry-point group at import (checked on 1.4.0:
``gymnasium/envs/__init__.py`` registers only its own environments), so the id is registered when this
module is imported; the module-qualified id ``gymnasium.make("amr_evaluation.gym_env:amr/Maze-v0")`` imports it
by itself, in any process (a SubprocVecEnv's or an async vector env's workers included). The package still
declares that entry point (``register_envs``) for tools that read it.

Observation (``Box`` float32, every value finite): the LiDAR ranges divided by ``range_max``, clipped to
[0, 1] (no return, REP 117's +inf, reads 1; a return closer than ``range_min``, -inf, reads 0), every
``scan_stride``-th beam of the 240; the encoder odometry's twist, v / max_linear and w / max_angular,
clipped to [-1, 1]; the goal in the robot frame, (x, y) / ``goal_scale`` clipped to [-1, 1].

Action: ``Box(-1, 1, (2,))``, scaled to the robot's limits (v = a0 * max_linear, w = a1 * max_angular: the robot
description's; the simulator saturates the wheels keeping the curvature, as the robot does). One step is one
``dt`` (0.05 s): the lockstep harness (amr_util.harness) steps the simulator with one part, the action.

Reward (each step; ``info["reward_terms"]`` has the four terms of the step, summing to the reward):

- progress: ``progress_weight`` x the metres gained toward the goal (straight-line distance; negative moving away);
  over an episode it sums to ``progress_weight`` x (first distance - last distance);
- step: ``-time_penalty`` every step;
- goal: ``+goal_reward`` on reaching the goal region (the episode ends: terminated, ``info["is_success"]``);
- collision: ``-collision_cost`` on a new wall contact, where collision_cost = ``collision_penalty`` + the
  largest cost of not crashing the episode can reach: ``progress_weight`` x ``reach`` + ``time_penalty`` x
  ``max_steps`` + ``goal_reward`` (a contact in the step that reaches the goal, or after one when contacts do
  not end the episode, still cannot pay). ``reach`` bounds how far from the goal
  the robot can get: the farthest corner of the world's bounds when its walls enclose the start, at most the
  first distance plus what ``max_steps`` at full speed covers. So a run with a contact never scores better than
  any run without one: it gains at most ``progress_weight`` x the first distance, and a run without a contact
  loses at most ``progress_weight`` x ``reach`` + ``time_penalty`` x ``max_steps``. Standing still for the
  whole episode costs ``time_penalty`` x ``max_steps`` (20 by default); crashing costs more than that.

Terminated at the goal or on a contact (``terminate_on_collision``); truncated after ``max_steps`` steps.

World: ``world`` fixed (a shipped name, a path, or a world spec of amr_evaluation.worlds), or drawn at each
``reset(seed=...)`` from ``families`` (default: all of amr_maps.maze_families) with a maze seed
from the environment's generator, so the same seed gives the same world, start, noise and episode. A
world without a goal gets its farthest free point as one. ``random_start_goal=True`` (a fixed world only) draws a
new start (free cell ``START_CLEARANCE`` from the walls, any heading) and goal (another such cell over
``MIN_GOAL_DISTANCE`` away, radius ``GOAL_RADIUS``) at each reset, both in the largest region of the free space
the robot can drive through, from the reset's seed.

Info (reset and step): ``world`` (name), ``time`` (s simulated), ``goal_distance`` (m, straight line),
``collisions`` (contacts so far), ``collided`` (a new contact this step), ``goal_reached``, ``is_success`` (the
goal reached: what Stable-Baselines3's Monitor and callbacks read), ``sim_seed``, ``start`` ([x, y, theta]),
``goal`` ([x, y, radius]), ``collision_cost`` (this episode's), ``reward_terms`` ({progress, step, goal,
collision}: this step's; zeros at reset).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from amr_evaluation.worlds import GOAL_RADIUS, GOAL_RESOLUTION, build_world, with_goal, world_spec_of_file
from amr_maps.maze_families import FAMILIES
from amr_maps.rasterize import rasterize_world
from amr_maps.world import Goal, World
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.geometry import Pose2D
from amr_util.harness import Frame, Harness, OneRobot
from amr_util.scan import ScanData

ENV_ID = "amr/Maze-v0"
QUALIFIED_ENV_ID = f"amr_evaluation.gym_env:{ENV_ID}"
"""The id that imports this module (and so registers ENV_ID) wherever gymnasium.make runs."""
START_CLEARANCE = 0.16
"""m from the walls of a random start or goal (random_start_goal), as the fleet worlds place their robots."""
MIN_GOAL_DISTANCE = 1.0
"""m, the least straight-line distance from a random start to its goal."""
ENCLOSURE_RESOLUTION = 0.05
"""m/cell of the grid that tells whether a world's walls enclose the start (the reach of collision_cost)."""


def enclosed(world: World, resolution: float = ENCLOSURE_RESOLUTION) -> bool:
    """Whether the world's solids close the start in: its free cells (4-connected) never reach the grid's edge."""
    from scipy.ndimage import label

    grid = rasterize_world(world, resolution)
    free = ~grid.occupied()
    row, col = (int(v) for v in grid.world_to_cell(world.start.x, world.start.y))
    if not (grid.inside(row, col) and free[row, col]):
        return False
    regions, _ = label(free)
    mine = regions == regions[row, col]
    return not (mine[0].any() or mine[-1].any() or mine[:, 0].any() or mine[:, -1].any())


def reach(world: World, travel: float) -> float:
    """m: how far from the world's goal the robot can get in an episode covering at most `travel` m."""
    goal, start = world.goal, world.start
    first = math.hypot(goal.x - start.x, goal.y - start.y)
    if not enclosed(world):
        return first + travel
    xmin, ymin, xmax, ymax = world.bounds
    corners = max(math.hypot(x - goal.x, y - goal.y) for x in (xmin, xmax) for y in (ymin, ymax))
    return min(corners, first + travel)


class MazeEnv(gymnasium.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self,
        world: str | dict | None = None,
        families: Sequence[str] | None = None,
        maze_options: dict | None = None,
        max_steps: int = 2000,
        scan_stride: int = 1,
        lidar_noise: float = 0.01,
        encoder_noise: float = 0.0,
        slip: float = 0.0,
        progress_weight: float = 10.0,
        time_penalty: float = 0.01,
        goal_reward: float = 10.0,
        collision_penalty: float = 10.0,
        terminate_on_collision: bool = True,
        goal_scale: float = 10.0,
        random_start_goal: bool = False,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode {render_mode!r}: expected one of {self.metadata['render_modes']}")
        if world is not None and families is not None:
            raise ValueError("give a fixed world or families to draw from, not both")
        if random_start_goal and world is None:
            raise ValueError("random_start_goal draws starts and goals on a fixed world: give world=")
        weights = {
            "progress_weight": progress_weight,
            "time_penalty": time_penalty,
            "goal_reward": goal_reward,
            "collision_penalty": collision_penalty,
        }
        bad = {name: value for name, value in weights.items() if not (math.isfinite(value) and value >= 0.0)}
        if bad or collision_penalty <= 0.0:
            raise ValueError(f"reward weights must be finite and >= 0 (collision_penalty > 0), got {bad or weights}")
        if max_steps < 1 or scan_stride < 1 or goal_scale <= 0:
            raise ValueError(
                f"max_steps and scan_stride must be >= 1 and goal_scale > 0, got {max_steps}, "
                f"{scan_stride}, {goal_scale}"
            )
        self.world_spec = world_spec_of_file(world) if isinstance(world, str) else world
        self.families = None if world is not None else tuple(families or FAMILIES)
        unknown = [f for f in self.families or () if f not in FAMILIES]
        if unknown:
            raise ValueError(f"families: unknown {unknown[0]!r} (known: {', '.join(FAMILIES)})")
        self.maze_options = dict(maze_options or {})
        self.max_steps = int(max_steps)
        self.config = SimulationConfig(
            lidar=LidarConfig(noise_std=lidar_noise), encoders=EncoderConfig(noise=encoder_noise, slip=slip)
        )
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
        self.harness: Harness | None = None
        """the lockstep harness over ``sim`` (amr_util.harness): its one part commands the step's action."""
        self._command = (0.0, 0.0)
        self.sim_seed: int | None = None
        self.world_name = ""
        self._fixed_world = build_world(self.world_spec) if self.world_spec is not None else None
        self.random_start_goal = bool(random_start_goal)
        self._places = self._free_places(self._fixed_world) if self.random_start_goal else None
        self.world: World | None = None
        self.collision_cost = math.nan
        self._steps = 0
        self._distance = math.nan
        self._terms = dict.fromkeys(("progress", "step", "goal", "collision"), 0.0)

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
        if self._places is not None:
            world = self._random_start_goal(world, rng)
        if world.goal is None:
            world = with_goal(world, "far", self.sim_seed)
        self.world = world
        travel = self.robot.max_linear * self.config.dt * self.max_steps
        self.collision_cost = (
            self.collision_penalty
            + self.progress_weight * reach(world, travel)
            + self.time_penalty * self.max_steps
            + self.goal_reward
        )
        self.sim = Simulator(
            world,
            SimulationConfig(
                dt=self.config.dt, seed=self.sim_seed, robot=self.robot, lidar=self.lidar, encoders=self.config.encoders
            ),
        )
        self.harness = Harness(OneRobot(self.sim), [[self._act]])
        self.world_name = world.name
        self._steps = 0
        self._distance = self._goal_distance()
        self._terms = dict.fromkeys(self._terms, 0.0)
        return self._observation(), self._info()

    def step(self, action):
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        action = np.asarray(action, dtype=float).reshape(2)
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action {action.tolist()}: must be finite")
        action = np.clip(action, -1.0, 1.0)
        collisions = self.sim.collisions
        self._command = (float(action[0]) * self.robot.max_linear, float(action[1]) * self.robot.max_angular)
        self.harness.step()
        self._steps += 1
        distance = self._goal_distance()
        collided = self.sim.collisions > collisions
        reached = self.sim.goal_reached
        self._terms = {
            "progress": self.progress_weight * (self._distance - distance),
            "step": -self.time_penalty,
            "goal": self.goal_reward if reached else 0.0,
            "collision": -self.collision_cost if collided else 0.0,
        }
        self._distance = distance
        reward = sum(self._terms.values())
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
        return ScanData(
            ranges,
            self.lidar.angle_min,
            self.lidar.angle_increment * self.scan_stride,
            self.lidar.range_min,
            self.lidar.range_max,
        )

    def twist_of_observation(self, observation: np.ndarray) -> tuple[float, float]:
        v, w = observation[len(self.beam_indices) : len(self.beam_indices) + 2]
        return float(v) * self.robot.max_linear, float(w) * self.robot.max_angular

    def action_of_command(self, v: float, w: float) -> np.ndarray:
        """A (v, w) command in m/s and rad/s as this environment's normalized action."""
        return np.clip(np.array([v / self.robot.max_linear, w / self.robot.max_angular], dtype=np.float32), -1, 1)

    @staticmethod
    def _free_places(world: World) -> np.ndarray:
        """(N, 2) cell centres a random start or goal may take: START_CLEARANCE from the walls, in the largest
        region of the free space the robot can drive through (8-connected cells clear of its radius)."""
        from amr_planning.costmap import Costmap

        costmap = Costmap(rasterize_world(world, GOAL_RESOLUTION))
        regions = costmap.regions()
        if regions.max() == 0:
            raise ValueError(f"{world.name}: no free space for random starts and goals")
        largest = 1 + int(np.argmax(np.bincount(regions.ravel())[1:]))
        rows, cols = np.nonzero((costmap.clearance >= START_CLEARANCE) & (regions == largest))
        points = costmap.centre(rows, cols)
        if len(points) < 2 or np.ptp(points, axis=0).max() <= MIN_GOAL_DISTANCE:
            raise ValueError(
                f"{world.name}: too little free space for random starts and goals {MIN_GOAL_DISTANCE} m apart"
            )
        return points

    def _random_start_goal(self, world: World, rng: np.random.Generator) -> World:
        """`world` with a start and a goal drawn from `rng` (random_start_goal)."""
        places = self._places
        for _ in range(100):
            start = places[int(rng.integers(len(places)))]
            far = np.flatnonzero(np.hypot(*(places - start).T) > MIN_GOAL_DISTANCE)
            if far.size:
                goal = places[int(far[int(rng.integers(far.size))])]
                break
        else:
            raise ValueError(f"{world.name}: no goal {MIN_GOAL_DISTANCE} m from the starts drawn")
        heading = float(rng.uniform(-math.pi, math.pi))
        return dataclasses.replace(
            world,
            start=Pose2D(float(start[0]), float(start[1]), heading),
            goal=Goal(float(goal[0]), float(goal[1]), GOAL_RADIUS),
            robots=(),
        )

    def _act(self, frame: Frame) -> None:
        """The harness's part: the step's action, scaled to the robot's limits."""
        frame.command = self._command

    def _goal_distance(self) -> float:
        pose, goal = self.sim.pose, self.sim.goal
        return math.hypot(goal.x - pose.x, goal.y - pose.y)

    def _observation(self) -> np.ndarray:
        sim = self.sim
        (seen,) = self.harness.simulation.observe()  # what the nodes see; the goal in the robot frame is the truth's
        beams = len(self.beam_indices)
        observation = np.empty(beams + 4, dtype=np.float32)
        scan = seen.scan.ranges[self.beam_indices] / self.lidar.range_max
        np.clip(scan, 0.0, 1.0, out=scan)  # +inf (no return) -> 1, -inf (closer than range_min) -> 0
        scan[np.isnan(scan)] = 1.0
        observation[:beams] = scan
        v, w = seen.twist
        pose, goal = sim.pose, sim.goal
        dx, dy = goal.x - pose.x, goal.y - pose.y
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        for index, value in enumerate(
            (
                v / self.robot.max_linear,
                w / self.robot.max_angular,
                (c * dx + s * dy) / self.goal_scale,
                (-s * dx + c * dy) / self.goal_scale,
            )
        ):
            observation[beams + index] = min(1.0, max(-1.0, value)) if math.isfinite(value) else 0.0
        return observation

    def _info(self, collided: bool = False) -> dict[str, Any]:
        sim = self.sim
        start, goal = self.world.start, sim.goal
        return {
            "world": self.world_name,
            "time": sim.time,
            "goal_distance": self._distance,
            "collisions": sim.collisions,
            "collided": collided,
            "goal_reached": sim.goal_reached,
            "is_success": bool(sim.goal_reached),
            "sim_seed": self.sim_seed,
            "start": [start.x, start.y, start.theta],
            "goal": [goal.x, goal.y, goal.radius],
            "collision_cost": self.collision_cost,
            "reward_terms": dict(self._terms),
        }


# -- reference policies: what a return is measured against (the tests' orders, bench_evaluate's returns) -----------


def standing_still(observation) -> np.ndarray:
    return np.zeros(2, dtype=np.float32)


def full_speed_ahead(observation) -> np.ndarray:
    """Never turning: into the first wall ahead."""
    return np.array([1.0, 0.0], dtype=np.float32)


def toward_the_goal(observation) -> np.ndarray:
    """Turn toward the goal (the observation's last two values: its x, y in the robot frame), then drive to it."""
    x, y = float(observation[-2]), float(observation[-1])
    bearing = math.atan2(y, x)
    return np.array([1.0 if abs(bearing) < 0.3 else 0.0, np.clip(2.0 * bearing, -1.0, 1.0)], dtype=np.float32)


REFERENCE_POLICIES = {
    "standing still": standing_still,
    "full speed ahead": full_speed_ahead,
    "toward the goal": toward_the_goal,
}


def episode_return(env: MazeEnv, policy, seed: int, on_step=None) -> tuple[float, dict, dict]:
    """(return, the first info, the last info) of one episode of `policy(observation) -> action` from
    `env.reset(seed=seed)`; `on_step(reward, info)` is called after each step."""
    observation, first = env.reset(seed=seed)
    total, info = 0.0, first
    for _ in range(env.max_steps):
        observation, reward, terminated, truncated, info = env.step(policy(observation))
        if on_step is not None:
            on_step(reward, info)
        total += reward
        if terminated or truncated:
            break
    return total, first, info


def register_envs() -> None:
    """Register amr/Maze-v0 with gymnasium (idempotent)."""
    if ENV_ID not in gymnasium.registry:
        gymnasium.register(id=ENV_ID, entry_point="amr_evaluation.gym_env:MazeEnv")


register_envs()
