"""amr/Maze-v0: the Gymnasium API contract, vector modes, determinism, and the wall follower as a policy."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import WallFollowerConfig
from amr_evaluation import configs
from amr_evaluation.gym_env import (
    ENV_ID,
    MIN_GOAL_DISTANCE,
    QUALIFIED_ENV_ID,
    START_CLEARANCE,
    MazeEnv,
    episode_return,
    full_speed_ahead,
    standing_still,
    toward_the_goal,
)
from amr_evaluation.wall_follower_loop import run
from amr_evaluation.worlds import build_world
from amr_util.environment import child_environment


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
    assert all(np.array_equal(a[0], b[0]) for a, b in zip(first[1:], again[1:], strict=True))
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
    for _ in range(steps):
        command = follower.compute(
            env.scan_of_observation(observation), *env.twist_of_observation(observation), env.sim.time
        )
        observation, _, terminated, truncated, info = env.step(env.action_of_command(command.v, command.w))
        if terminated or truncated:
            break
    return bool(info["goal_reached"]), env.sim_seed


@pytest.mark.parametrize(
    ("world", "seconds", "expected"),
    [
        ("open_room", 60.0, True),  # reached at 37.6 s
        ({"family": "narrowing", "seed": 2, "options": {"hand": "right"}}, 70.0, True),  # at about 58 s
        ({"family": "perfect", "seed": 2, "options": {"hand": "right", "size": 3.0}}, 20.0, False),
        ("pillar_goal", 20.0, False),  # no wall follower reaches it
    ],
)
def test_the_wall_follower_as_a_policy_reaches_the_goals_it_reaches_in_the_closed_loop(world, seconds, expected):
    config = WallFollowerConfig.from_params(configs.shipped_parameters("wall_follower", "sim"))
    reached, sim_seed = _follow_through_env(world, int(seconds / 0.05), config)
    spec = world if isinstance(world, dict) else {"file": f"{world}.yaml"}
    closed_loop = run(build_world(spec), config, seconds, lidar_noise=0.01, seed=sim_seed)
    assert closed_loop.goal is expected  # the case is what it claims to be
    assert reached is expected


def _terms_sum_to_the_reward(reward: float, info: dict) -> None:
    assert sum(info["reward_terms"].values()) == pytest.approx(reward)


def _episode(env: MazeEnv, policy, seed: int) -> tuple[float, dict, dict]:
    """(return, the first info, the last info) of one episode of `policy(observation) -> action`."""
    return episode_return(env, policy, seed, on_step=_terms_sum_to_the_reward)


def test_crashing_never_pays_still_crash_first_and_a_good_policy():
    env = MazeEnv(world="open_room", max_steps=600)
    good, _, good_end = _episode(env, toward_the_goal, 0)
    stand, _, stand_end = _episode(env, standing_still, 0)
    crash, _, crash_end = _episode(env, full_speed_ahead, 0)
    assert good_end["is_success"] and good_end["goal_reached"] and good_end["collisions"] == 0
    assert not stand_end["is_success"] and stand_end["collisions"] == 0
    assert stand == pytest.approx(-env.time_penalty * env.max_steps, abs=1e-6)  # the step cost, nothing else
    assert crash_end["collided"] and not crash_end["is_success"]
    assert good > 0.0 > stand > crash


@pytest.mark.parametrize("world", ["inner_maze", "outer_corridor", "hard_maze"])
def test_a_crash_scores_below_the_worst_run_without_one(world):
    """From random starts and goals: every crash-first episode scores below what any run without a contact can
    score at worst (it moves as far from the goal as the world lets it, for every step), and below standing."""
    env = MazeEnv(world=world, max_steps=400, random_start_goal=True, lidar_noise=0.0)
    travel = env.robot.max_linear * env.config.dt * env.max_steps
    for seed in range(4):
        crash, first, end = _episode(env, full_speed_ahead, seed)
        assert end["collided"], "the case is what it claims to be"
        goal = first["goal"]
        xmin, ymin, xmax, ymax = env.world.bounds
        farthest = min(
            max(np.hypot(x - goal[0], y - goal[1]) for x in (xmin, xmax) for y in (ymin, ymax)),
            first["goal_distance"] + travel,
        )
        worst_without = env.progress_weight * (first["goal_distance"] - farthest) - env.time_penalty * env.max_steps
        assert crash < worst_without
        assert crash < _episode(env, standing_still, seed)[0]


def test_random_starts_and_goals_come_from_the_reset_seed():
    env = MazeEnv(world="inner_maze", random_start_goal=True)
    places = [env.reset(seed=seed)[1] for seed in (3, 3, 4)]
    assert places[0]["start"] == places[1]["start"] and places[0]["goal"] == places[1]["goal"]
    assert places[0]["start"] != places[2]["start"]
    for info in places:
        start, goal = np.array(info["start"][:2]), np.array(info["goal"][:2])
        assert np.hypot(*(goal - start)) > MIN_GOAL_DISTANCE
        assert env.world.clearance(np.array([start, goal])).min() >= START_CLEARANCE - 0.02
    assert (env.sim.pose.x, env.sim.pose.y) == pytest.approx(places[2]["start"][:2])  # the simulator starts there
    assert (env.sim.goal.x, env.sim.goal.y) == pytest.approx(places[2]["goal"][:2])
    fixed = MazeEnv(world="inner_maze")
    assert fixed.reset(seed=3)[1]["start"] == fixed.reset(seed=4)[1]["start"]  # off: the world's own
    with pytest.raises(ValueError, match="fixed world"):
        MazeEnv(random_start_goal=True)


def test_every_info_key_is_there_at_reset_and_step():
    env = MazeEnv(world="open_room", max_steps=5)
    keys = {
        "world",
        "time",
        "goal_distance",
        "collisions",
        "collided",
        "goal_reached",
        "is_success",
        "sim_seed",
        "start",
        "goal",
        "collision_cost",
        "reward_terms",
    }
    _, info = env.reset(seed=0)
    assert set(info) == keys and info["reward_terms"] == {"progress": 0.0, "step": 0.0, "goal": 0.0, "collision": 0.0}
    assert set(env.step(standing_still(None))[4]) == keys
    assert info["collision_cost"] > env.time_penalty * env.max_steps + env.goal_reward


def test_the_qualified_id_registers_in_a_fresh_process():
    """What a SubprocVecEnv's worker does: gymnasium.make with the module-qualified id, nothing imported first."""
    import subprocess
    import sys

    code = (
        f"import gymnasium; env = gymnasium.make({QUALIFIED_ENV_ID!r}, world='open_room', max_steps=3); "
        "print(env.reset(seed=0)[1]['world'])"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], env=child_environment(), capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "open_room"
