"""The core against the original system's reference numbers (docs/original-system.md, appendix)."""
import numpy as np
import pytest

from mahn_envs import BatchSim, patrol_return_v0
from mahn_envs.core import TaskParams
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_envs.policies.scripted import run_scripted_episode

from .helpers import random_team

H = 187.0075  # mirror: y = H - y_orig


def test_all_forward_team_scores_the_seed_genome_fitness():
    sim = BatchSim("plus", 1)
    sim.reset(0)
    first = []
    while not sim.done:
        sim.step(np.ones((1, 3), dtype=np.int64))
        if sim.tick <= 2:
            first.append(sim.pose[0, 0, :2].copy())
    fitness, solved = sim.team_fitness()
    assert fitness[0] == pytest.approx(2.0232671157474424, abs=1e-10)
    assert not solved[0]
    assert sim.goto[0] == pytest.approx([1.8795011150, 16.4973811925, 1.8557788499], abs=1e-9)
    assert first[0] == pytest.approx([93.5030404735, H - 117.8130008491], abs=1e-9)
    assert first[1] == pytest.approx([93.5023309470, H - 117.5160016983], abs=1e-9)
    # everyone ends against the top wall (y_orig ~ 8.52), no collisions
    assert sim.pose[0, :, 1] == pytest.approx(H - 8.52, abs=0.01)
    assert sim.racc[0, :, 3].sum() == 0


def test_start_formation_reproduces_the_314_quirk():
    sim = BatchSim("plus", 1)
    sim.reset(0)
    assert sim.pose[0, :, 0] == pytest.approx([93.50375, 93.527639801322, 93.551529602644], abs=1e-9)
    assert sim.pose[0, :, 1] == pytest.approx([H - 118.11, H - 148.109990487955, H - 178.10998097591], abs=1e-9)
    assert np.all(sim.pose[0, :, 2] == -4.71)


def test_corridor_sensor_sanity_values():
    # centred in an arm, the +-76.8 deg sensors read 15.17 (input 0.853), the others see nothing
    sim = BatchSim("plus", 1)
    obs = sim.reset(0, poses=np.array([[93.50375, 40.0, np.pi / 2], [93.50375, 20.0, np.pi / 2],
                                      [40.0, 93.50375, 0.0]]))
    assert sim.raw[0, 0, [0, 5]] == pytest.approx(15.17, abs=0.01)
    assert obs[0, 0, [0, 5]] == pytest.approx(0.853, abs=0.001)
    assert np.all(obs[0, 0, 1:5] == 1.0)


def test_scripted_team_solves_the_plus_map():
    env = patrol_return_v0.parallel_env()
    fitness, solved, poses = run_scripted_episode(env, seed=0)
    assert solved
    assert fitness > 160
    pois = env.world.pois
    at_signal = poses[690]
    for r, p in enumerate([0, 2, 1]):  # each robot was at its own POI when the signal came
        assert np.abs(at_signal[r, :2] - pois[p]).sum() < 15


def test_team_frozen_after_the_signal_is_not_solved():
    env = patrol_return_v0.parallel_env()
    from mahn_envs.policies.scripted import WaypointTeam

    obs, infos = env.reset(seed=0)
    team = WaypointTeam(env.world, env.possible_agents)
    while env.sim.tick < 690:
        obs, rew, te, tr, infos = env.step(team.act(infos))
    while not env.sim.done:  # the internal "no decision" action: robots stand still
        env.sim.step(np.full((1, 3), 3), validate=False)
    fitness, solved = env.sim.team_fitness()
    assert not solved[0]
    assert fitness[0] < 100


def test_episode_rewards_sum_to_team_fitness():
    env = patrol_return_v0.parallel_env()
    from mahn_envs.policies.scripted import WaypointTeam

    obs, infos = env.reset(seed=0)
    team = WaypointTeam(env.world, env.possible_agents)
    totals = dict.fromkeys(env.possible_agents, 0.0)
    while env.agents:
        obs, rew, te, tr, infos = env.step(team.act(infos))
        for a, r in rew.items():
            totals[a] += r
    for a in env.possible_agents:
        assert totals[a] == pytest.approx(infos[a]["team_fitness"], abs=1e-9)
        assert infos[a]["solved"]


@pytest.mark.parametrize("brains", [1, 2])
def test_controllers_in_core_and_env_agree(brains):
    team = random_team(3 + brains, n_brains=brains)
    res = BatchSim("plus", 1).run_controllers(team, seed=0)
    env = patrol_return_v0.parallel_env()
    obs, _ = env.reset(seed=0)
    policy = ControllerPolicy(team, env.possible_agents)
    while env.agents:
        obs, rew, te, tr, infos = env.step(policy.act(obs))
    assert infos["robot_0"]["team_fitness"] == pytest.approx(res.fitness[0], abs=1e-9)


def test_batch_is_parallel_safe_and_order_independent():
    teams = [random_team(s, n_brains=2) for s in range(6)]
    from mahn_envs.policies.team_controllers import TeamControllers

    batch = TeamControllers.stack(teams)
    params = TaskParams(sensor_noise=5, effector_noise=5, heading_noise=0.01)
    together = BatchSim("plus", 6, params).run_controllers(batch, seed=9, episode_keys=[0] * 6)
    alone = [BatchSim("plus", 1, params).run_controllers(t, seed=9, episode_keys=[0]).fitness[0] for t in teams]
    assert together.fitness == pytest.approx(alone, abs=0)
    again = BatchSim("plus", 6, params).run_controllers(batch, seed=9, episode_keys=[0] * 6)
    assert np.array_equal(together.fitness, again.fitness)
