"""SB3's own checks and wrappers accept our envs; SB3's `seed=` makes training reproducible; SuperSuit route."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.env_checker import check_env  # noqa: E402
from stable_baselines3.common.evaluation import evaluate_policy  # noqa: E402
from stable_baselines3.common.vec_env import VecCheckNan, VecEnv, VecMonitor, VecNormalize  # noqa: E402

from baselines.sb3.gym_env import PatrolReturnTeamEnv  # noqa: E402
from baselines.vec_env import PatrolReturnVecEnv, register_with_sb3  # noqa: E402

torch.set_num_threads(1)
register_with_sb3()


def test_sb3_check_env_on_gym_view() -> None:
    check_env(PatrolReturnTeamEnv(max_cycles=60, signal_tick=30), warn=True)


def test_gym_view_matches_vec_env() -> None:
    env = PatrolReturnTeamEnv(max_cycles=60, signal_tick=30)
    venv = PatrolReturnVecEnv(1, max_cycles=60, signal_tick=30)
    obs, _ = env.reset(seed=4)
    venv.seed(4)
    vobs = venv.reset()
    rng = np.random.default_rng(0)
    for _ in range(60):
        np.testing.assert_array_equal(obs, vobs.reshape(-1))
        a = rng.integers(0, 3, 3)
        obs, rew, term, trunc, info = env.step(a)
        vobs, vrew, vdone, vinfo = venv.step(a)
        assert rew == pytest.approx(float(vrew[0]), rel=1e-6, abs=1e-7) and trunc == bool(vdone[0]) and not term
    assert info["team_fitness"] == vinfo[0]["team_fitness"]


def test_is_an_sb3_vec_env_and_wraps() -> None:
    venv = PatrolReturnVecEnv(2, max_cycles=30, signal_tick=30)
    assert isinstance(venv, VecEnv)
    wrapped = VecNormalize(VecMonitor(VecCheckNan(venv, raise_exception=True)), norm_obs=False)
    wrapped.seed(0)
    wrapped.reset()
    for _ in range(61):
        _, _, done, infos = wrapped.step(np.ones(venv.num_envs, dtype=np.int64))
    assert wrapped.get_attr("n_robots") == [3] * venv.num_envs


def test_sb3_seed_makes_training_reproducible() -> None:
    def run(seed: int) -> np.ndarray:
        env = PatrolReturnVecEnv(2, max_cycles=60, signal_tick=30, sensor_noise=5.0, start_jitter_xy=2.0)
        model = PPO("MlpPolicy", env, seed=seed, n_steps=64, batch_size=128, n_epochs=2, device="cpu")
        model.learn(384)
        assert env._seed == seed  # SB3's seed reached the simulator
        return torch.nn.utils.parameters_to_vector(model.policy.parameters()).detach().numpy()

    a, b, c = run(11), run(11), run(12)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_evaluate_policy_runs_on_vec_env() -> None:
    env = PatrolReturnVecEnv(1, max_cycles=60, signal_tick=30)
    model = PPO("MlpPolicy", env, seed=0, n_steps=64, device="cpu")
    with pytest.warns(UserWarning):  # "not wrapped with a Monitor": we write the episode info ourselves
        mean, _ = evaluate_policy(model, env, n_eval_episodes=3)
    assert np.isfinite(mean)


def test_supersuit_route_runs() -> None:
    pytest.importorskip("supersuit")
    import supersuit as ss

    from mahn_envs import patrol_return_v0

    pz = patrol_return_v0.parallel_env(max_cycles=30, signal_tick=30)
    venv = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(pz), 2, num_cpus=0,
                                 base_class="stable_baselines3")
    obs = venv.reset()
    assert obs.shape == (6, 7)
    for _ in range(30):
        obs, rew, done, infos = venv.step(np.ones(6, dtype=np.int64))
    assert done.all()
    venv.close()


def test_supersuit_example_runs() -> None:
    import pathlib
    import subprocess
    import sys

    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "supersuit_ppo.py"
    out = subprocess.run([sys.executable, str(example), "--steps", "600", "--envs", "2", "--max-cycles", "60"],
                         check=True, capture_output=True, text=True).stdout
    assert "team fitness" in out
