"""PettingZoo contract: official API tests plus our own multi-step determinism and contract checks."""
import numpy as np
import pettingzoo
import pytest
from pettingzoo.test import api_test, max_cycles_test, parallel_api_test, render_test

import mahn_envs
from mahn_envs import patrol_return_v0


def test_parallel_api():
    parallel_api_test(patrol_return_v0.parallel_env(max_cycles=200), num_cycles=300)


def test_aec_api():
    api_test(patrol_return_v0.env(max_cycles=100), num_cycles=150)


def test_max_cycles():
    max_cycles_test(patrol_return_v0)


def test_render_modes():
    render_test(lambda render_mode=None: patrol_return_v0.env(render_mode=render_mode, max_cycles=20))


def test_rgb_frame_shows_the_arena():
    env = patrol_return_v0.parallel_env(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert (frame < 100).all(axis=2).sum() > 500  # dark wall pixels are drawn
    env.close()


def test_registered_with_pettingzoo():
    env = pettingzoo.make("parallel", mahn_envs.ENV_ID, map="asymmetric_plus")
    assert env.world.name == "asymmetric_plus"
    aec = pettingzoo.make("aec", mahn_envs.ENV_ID)
    aec.reset(seed=1)
    assert aec.agents == ["robot_0", "robot_1", "robot_2"]


def test_spaces_infos_and_policy_coordinates():
    env = patrol_return_v0.parallel_env()
    obs, infos = env.reset(seed=0)
    assert env.possible_agents == ["robot_0", "robot_1", "robot_2"]
    for a in env.possible_agents:
        assert env.observation_space(a).shape == (7,) and env.observation_space(a).dtype == np.float32
        assert env.action_space(a).n == 3
        assert env.observation_space(a).contains(obs[a])
        assert set(infos[a]) >= {"pose", "signal"}
    assert list(env.policy_coordinates.values()) == [-1.0, 0.0, 1.0]
    assert env.state().shape == env.state_space.shape


def test_signal_arrives_at_tick_690_in_observations():
    env = patrol_return_v0.parallel_env()
    obs, _ = env.reset(seed=0)
    for t in range(1, 691):
        obs, *_ , infos = env.step({a: 1 for a in env.agents})
        assert obs["robot_0"][6] == (1.0 if t >= 690 else 0.0)
        assert infos["robot_1"]["signal"] == (t >= 690)


def _rollout(seed, noise=True):
    kw = dict(sensor_noise=10, effector_noise=10, heading_noise=0.02, start_jitter_xy=2, start_jitter_heading=0.1) \
        if noise else {}
    env = patrol_return_v0.parallel_env(max_cycles=400, **kw)
    obs, _ = env.reset(seed=seed)
    trace = []
    while env.agents:
        actions = {a: env.action_space(a).sample() for a in env.agents}
        obs, rew, te, tr, infos = env.step(actions)
        trace.append((np.concatenate([obs[a] for a in sorted(obs)]), rew["robot_0"],
                      [infos[a]["pose"] for a in sorted(infos)]))
    return trace


def test_multi_step_determinism_with_noise():
    a, b, c = _rollout(5), _rollout(5), _rollout(6)
    assert len(a) == 400
    for (o1, r1, p1), (o2, r2, p2) in zip(a, b):
        assert np.array_equal(o1, o2) and r1 == r2 and p1 == p2
    assert any(not np.array_equal(x[0], y[0]) for x, y in zip(a, c))


def test_reset_places_robots_from_options():
    env = patrol_return_v0.parallel_env()
    _, infos = env.reset(seed=0, options={"poses": {"robot_1": (93.5, 93.5, 0.0)}})
    assert infos["robot_1"]["pose"] == pytest.approx((93.5, 93.5, 0.0))
    assert infos["robot_0"]["pose"] == pytest.approx(tuple(env.world.starts[0]))


def test_operator_signal_without_auto_signal():
    env = patrol_return_v0.parallel_env(auto_signal=False, max_cycles=800)
    obs, _ = env.reset(seed=0)
    for _ in range(700):
        obs, *_ = env.step({a: 1 for a in env.agents})
    assert obs["robot_0"][6] == 0.0
    env.call_home("robot_2")
    obs, *_, infos = env.step({a: 1 for a in env.agents})
    assert obs["robot_2"][6] == 1.0 and obs["robot_0"][6] == 0.0
    env.clear_signal("robot_2")
    obs, *_ = env.step({a: 1 for a in env.agents})
    assert obs["robot_2"][6] == 0.0
