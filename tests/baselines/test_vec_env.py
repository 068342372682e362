"""The vector env is a view of the same core as the PettingZoo env: step-for-step equality, SB3 semantics."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from baselines.vec_env import N_SENSOR_INPUTS, PatrolReturnVecEnv
from mahn_envs import patrol_return_v0

NOISE = dict(sensor_noise=5.0, effector_noise=5.0, heading_noise=0.01, start_jitter_xy=2.0,
             start_jitter_heading=0.05)


def _compare_with_pettingzoo(n_episodes: int, max_cycles: int, seed: int, task: dict, map: str = "plus") -> None:
    """Drive B PettingZoo envs and one vec env with the same random actions; everything must match."""
    venv = PatrolReturnVecEnv(n_episodes, map=map, max_cycles=max_cycles, signal_tick=min(690, max_cycles // 60 * 30),
                              **task)
    envs = [patrol_return_v0.parallel_env(map=map, max_cycles=max_cycles,
                                          signal_tick=min(690, max_cycles // 60 * 30), **task)
            for _ in range(n_episodes)]
    R = venv.n_robots
    venv.seed(seed)
    vobs = venv.reset()
    pz_obs = [e.reset(seed=seed)[0] for e in envs]
    agents = envs[0].possible_agents
    rng = np.random.default_rng(seed)
    returns = np.zeros(venv.num_envs)
    for t in range(max_cycles):
        for b in range(n_episodes):
            for r, a in enumerate(agents):
                np.testing.assert_array_equal(vobs[b * R + r, :N_SENSOR_INPUTS], pz_obs[b][a], err_msg=f"tick {t}")
                onehot = np.zeros(R, dtype=np.float32)
                onehot[r] = 1
                np.testing.assert_array_equal(vobs[b * R + r, N_SENSOR_INPUTS:], onehot)
        actions = rng.integers(0, 3, venv.num_envs)
        vobs, vrew, vdone, vinfo = venv.step(actions)
        returns += vrew
        for b, env in enumerate(envs):
            act = {a: int(actions[b * R + r]) for r, a in enumerate(agents)}
            pz_obs[b], rew, term, trunc, info = env.step(act)
            for r, a in enumerate(agents):
                assert vrew[b * R + r] == pytest.approx(rew[a], rel=1e-6, abs=1e-7)
                assert bool(vdone[b * R + r]) == (term[a] or trunc[a])
                assert not term[a]
            if t == max_cycles - 1:
                for r, a in enumerate(agents):
                    i = vinfo[b * R + r]
                    assert i["TimeLimit.truncated"] is True and trunc[a]
                    np.testing.assert_array_equal(i["terminal_observation"][:N_SENSOR_INPUTS], pz_obs[b][a])
                    assert i["team_fitness"] == pytest.approx(info[a]["team_fitness"], rel=1e-12)
                    assert i["solved"] == info[a]["solved"]
                    assert i["episode"]["r"] == i["team_fitness"] and i["episode"]["l"] == max_cycles
                    # the rewards of an episode sum to its team fitness (the paper's score)
                    assert returns[b * R + r] == pytest.approx(i["team_fitness"], rel=1e-4, abs=1e-5)
            else:
                assert not vdone.any() and vinfo[b * R] == {}


def test_matches_pettingzoo_full_episode_batch() -> None:
    _compare_with_pettingzoo(n_episodes=2, max_cycles=1364, seed=0, task={})


def test_matches_pettingzoo_test_map() -> None:
    _compare_with_pettingzoo(n_episodes=2, max_cycles=240, seed=5, task={}, map="asymmetric_plus")


def test_matches_pettingzoo_with_noise() -> None:
    # with noise the streams are keyed by (seed, episode key): one vec episode = the PettingZoo env's episode
    _compare_with_pettingzoo(n_episodes=1, max_cycles=300, seed=7, task=NOISE)


def test_auto_reset_and_truncation() -> None:
    venv = PatrolReturnVecEnv(3, max_cycles=60, signal_tick=30)
    venv.seed(1)
    first = venv.reset()
    for _ in range(59):
        obs, _, done, infos = venv.step(np.ones(venv.num_envs, dtype=np.int64))
        assert not done.any()
    last_obs_before = obs
    obs, _, done, infos = venv.step(np.ones(venv.num_envs, dtype=np.int64))
    assert done.all() and all(i["TimeLimit.truncated"] for i in infos)
    np.testing.assert_array_equal(obs, first)  # auto-reset to the start poses
    assert not np.array_equal(infos[0]["terminal_observation"], first[0]) or \
        not np.array_equal(last_obs_before, first)
    assert venv.sim.tick == 0
    obs2, _, done2, _ = venv.step(np.ones(venv.num_envs, dtype=np.int64))  # and keeps going
    assert not done2.any() and venv.sim.tick == 1


def test_seeding_is_deterministic_and_keys_differ_per_episode() -> None:
    def run(seed: int, episodes: int = 2) -> np.ndarray:
        venv = PatrolReturnVecEnv(2, max_cycles=30, signal_tick=30, **NOISE)
        venv.seed(seed)
        out = [venv.reset()]
        rng = np.random.default_rng(0)
        for _ in range(30 * episodes):
            out.append(venv.step(rng.integers(0, 3, venv.num_envs))[0])
        return np.stack(out)

    a, b, c = run(3), run(3), run(4)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    # the two batch episodes and the first and second episode of a slot get different noise
    assert not np.array_equal(a[0, :3], a[0, 3:6])
    assert not np.array_equal(a[0], a[30])


def test_observation_space_and_bad_actions() -> None:
    venv = PatrolReturnVecEnv(2, max_cycles=30, signal_tick=30)
    venv.seed(0)
    obs = venv.reset()
    assert obs.dtype == np.float32 and obs.shape == (6, 10) and venv.observation_space.contains(obs[0])
    with pytest.raises(ValueError, match="one per slot"):
        venv.step(np.ones(5, dtype=np.int64))
    with pytest.raises(ValueError, match="0 \\(left\\)"):
        venv.step(np.full(6, 3))
    with pytest.raises(ValueError, match="reward_scale"):
        PatrolReturnVecEnv(1, reward_scale=0.0)


def test_reward_scale_leaves_episode_score_unscaled() -> None:
    venv = PatrolReturnVecEnv(1, max_cycles=240, signal_tick=120, reward_scale=0.01)
    venv.seed(0)
    venv.reset()
    total = 0.0
    for _ in range(240):
        _, rew, done, infos = venv.step(np.ones(3, dtype=np.int64))
        total += float(rew[0])
    assert infos[0]["episode"]["r"] == pytest.approx(total / 0.01, rel=1e-4)


def test_imports_without_torch() -> None:
    code = ("import sys; sys.modules['torch'] = None; sys.modules['stable_baselines3'] = None\n"
            "import baselines, baselines.vec_env, baselines.sb3.gym_env, baselines.protocols\n"
            "import baselines.comparison.compare\n"
            "import baselines.lean.config, baselines.direct.cmaes  # torch-free: configs and the CMA-ES control\n"
            "import baselines.cli; baselines.cli.build_parser()\n"
            "assert 'baselines.vec_env' in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_global_state_reads_the_core_state_a_centralised_critic_needs():
    env = PatrolReturnVecEnv(2, max_cycles=120, signal_tick=60)
    env.seed(0)
    env.reset()
    R, P = env.n_robots, env.sim.goto.shape[1]
    s = env.global_state()
    assert s.shape == (2, env.global_state_size) and s.dtype == np.float32
    assert env.global_state_size == 1 + 9 * R + P + 2
    assert s[0, 0] == 0.0 and np.all(s[:, -2:] == 0)
    for _ in range(61):
        env.step(np.ones(env.num_envs, dtype=np.int64))
    s = env.global_state()
    assert s[0, 0] == pytest.approx(61 / 120)
    assert s[0, -1] == 1.0  # the signal was given at tick 60
    robot = s[0, 1:1 + 9 * R].reshape(R, 9)
    assert np.all(robot[:, 4] == 1.0)  # every robot's signal flag
    np.testing.assert_allclose(robot[:, 0], (env.sim.pose[0, :, 0] - env.sim.world.bounds[0])
                               / (env.sim.world.bounds[2] - env.sim.world.bounds[0]), rtol=1e-6)
    np.testing.assert_allclose(s[0, 1 + 9 * R:1 + 9 * R + P], env.sim.goto[0] / 2, rtol=1e-6)
    assert np.all(s[0, 1 + 9 * R:1 + 9 * R + P] > 0)  # the robots drove towards the posts


def test_reset_at_continues_the_episode_sequence_of_a_seed():
    task = dict(max_cycles=30, signal_tick=30, start_jitter_xy=2.0, start_jitter_heading=0.1)
    a = PatrolReturnVecEnv(2, **task)
    a.seed(5)
    a.reset()
    for _ in range(2 * 30):  # two whole batches of episodes: the env auto-resets into the third
        obs_a, *_ = a.step(np.ones(a.num_envs, dtype=np.int64))
    b = PatrolReturnVecEnv(2, **task)
    np.testing.assert_array_equal(b.reset_at(5, 2), obs_a)
    np.testing.assert_array_equal(b.sim.pose, a.sim.pose)
    with pytest.raises(ValueError, match="episode"):
        b.reset_at(5, -1)
