"""amr/Maze-v0: the Gymnasium API contract, vector modes, determinism, and the wall follower as a policy."""

from __future__ import annotations

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from amr_control.wall_follower import WallFollower  # noqa: E402
from amr_evaluation import configs  # noqa: E402
from amr_evaluation.gym_env import ENV_ID, MazeEnv  # noqa: E402
from amr_evaluation.wall_follower_loop import run  # noqa: E402
from amr_evaluation.worlds import build_world  # noqa: E402
from amr_control.wall_follower_config import WallFollowerConfig  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402


def test_passes_the_gymnasium_env_checker():
    check_env(gymnasium.make(ENV_ID, max_steps=50).unwrapped)
    check_env(MazeEnv(world="hard_maze", max_steps=50, scan_stride=8))


def test_module_prefixed_id_registers_by_itself():
    env = gymnasium.make("amr_evaluation.gym_env:amr/Maze-v0", world="open_room", max_steps=10)
    observation, info = env.reset(seed=1)
    assert env.observation_space.contains(observation) and info["world"] == "open_room"


def test_observation_is_finite_and_normalized_and_action_limits_are_the_burgers():
    env = MazeEnv(families=["open_room"], max_steps=100)
    observation, _ = env.reset(seed=4)
    for _ in range(40):
        observation, reward, terminated, truncated, _ = env.step(np.array([1.0, 0.3], dtype=np.float32))
        assert np.all(np.isfinite(observation)) and env.observation_space.contains(observation)
        assert np.isfinite(reward)
        if terminated:
            break
    v, w = env.twist_of_observation(observation)
    assert 0.0 < v <= 0.22 + 1e-6 and abs(w) <= 2.84
    assert env.sim.time == pytest.approx(0.05 * 40)


def test_truncated_at_the_step_limit_terminated_on_contact():
    env = MazeEnv(world="outer_corridor", max_steps=5)
    env.reset(seed=0)
    flags = [env.step(np.zeros(2, dtype=np.float32))[2:4] for _ in range(5)]
    assert flags[-1] == (False, True) and all(f == (False, False) for f in flags[:-1])
    env = MazeEnv(world="outer_corridor", max_steps=2000)
    env.reset(seed=0)
    for _ in range(2000):  # full speed ahead until the wall
        _, reward, terminated, truncated, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        if terminated:
            break
    assert terminated and info["collided"] and reward < -5.0


def test_same_seed_same_episode_other_seed_other_world():
    def episode(seed: int) -> tuple[str, list]:
        env = MazeEnv(max_steps=30)
        observation, info = env.reset(seed=seed)
        rng = np.random.default_rng(0)
        trace = [observation]
        for _ in range(30):
            trace.append(env.step(rng.uniform(-1, 1, 2).astype(np.float32))[:2])
        return info["world"], trace

    world, first = episode(7)
    again_world, again = episode(7)
    assert world == again_world
    assert all(np.array_equal(a[0], b[0]) for a, b in zip(first[1:], again[1:]))
    assert [a[1] for a in first[1:]] == [b[1] for b in again[1:]]
    assert episode(8)[0] != world


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_make_vec_steps_both_modes(mode):
    envs = gymnasium.make_vec(ENV_ID, num_envs=2, vectorization_mode=mode, world="open_room", max_steps=20)
    try:
        observations, _ = envs.reset(seed=[1, 2])
        assert observations.shape == (2, envs.single_observation_space.shape[0])
        for _ in range(25):  # past the step limit: each copy truncates and resets (next-step autoreset)
            observations, rewards, terminated, truncated, _ = envs.step(envs.action_space.sample())
            assert np.all(np.isfinite(observations)) and rewards.shape == (2,)
    finally:
        envs.close()


def _follow_through_env(world: str | dict, steps: int, config: WallFollowerConfig) -> tuple[bool, int]:
    env = MazeEnv(world=world, max_steps=steps, lidar_noise=0.01)
    observation, info = env.reset(seed=0)
    follower = WallFollower(config)
    for step in range(steps):
        command = follower.compute(env.scan_of_observation(observation), *env.twist_of_observation(observation),
                                   env.sim.time)
        observation, _, terminated, truncated, info = env.step(env.action_of_command(command.v, command.w))
        if terminated or truncated:
            break
    return bool(info["goal_reached"]), env.sim_seed


@pytest.mark.parametrize(("world", "seconds", "expected"), [
    ("open_room", 60.0, True),                                                         # reached at 37.6 s
    ({"family": "narrowing", "seed": 2, "options": {"hand": "right"}}, 70.0, True),  # at about 58 s
    ({"family": "perfect", "seed": 2, "options": {"hand": "right", "size": 3.0}}, 20.0, False),
    ("pillar_goal", 20.0, False),                                              # no wall follower reaches it
])
def test_the_wall_follower_as_a_policy_reaches_the_goals_it_reaches_in_the_closed_loop(world, seconds, expected):
    config = WallFollowerConfig.from_params(configs.shipped_parameters("wall_follower", "sim"))
    reached, sim_seed = _follow_through_env(world, int(seconds / 0.05), config)
    spec = world if isinstance(world, dict) else {"file": f"{world}.yaml"}
    closed_loop = run(build_world(spec), config, seconds, lidar_noise=0.01, seed=sim_seed)
    assert closed_loop.goal is expected  # the case is what it claims to be
    assert reached is expected
