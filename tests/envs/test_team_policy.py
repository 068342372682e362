"""One team-policy interface: an evolved team runs through the RL baselines' protocols, and its batch and dict
forms act identically."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_envs.policies.team_policy import TeamPolicy
from mahn_evo.training.champion import Champion

PUBLISHED = Path(__file__).parents[2] / "docs" / "results" / "experiment_mahn_0.1" / "champions"
CHAMPION = PUBLISHED / "situational_s012.json"
AGENTS = ["robot_0", "robot_1", "robot_2"]


def test_an_evolved_team_scores_its_exact_fitness_through_the_baselines_training_protocol():
    from baselines.protocols import run_protocol
    champ = Champion.load(CHAMPION)
    policy = ControllerPolicy(champ.controllers, AGENTS)
    assert isinstance(policy, TeamPolicy)
    scores = run_protocol("training", policy, "plus", episodes=3, seed=0)
    assert scores.fitness.shape == (3,) and np.all(scores.solved)
    assert np.all(scores.fitness == scores.fitness[0])  # no noise: three identical episodes
    assert scores.fitness[0] == pytest.approx(champ.fitness, abs=1e-9)


def test_batch_and_dict_forms_act_identically_and_reset_clears_the_state():
    champ = Champion.load(CHAMPION)
    a, b = ControllerPolicy(champ.controllers, AGENTS), ControllerPolicy(champ.controllers, AGENTS)
    rng = np.random.default_rng(3)
    obs = rng.random((40, 3, 7)).astype(np.float32)
    obs[20:, :, 6] = 1.0  # the signal: situational teams switch brains
    first = []
    for t in range(40):
        batch = a.act_batch(obs[t][None])[0]
        d = b.act({agent: obs[t, r] for r, agent in enumerate(AGENTS)})
        assert [d[agent] for agent in AGENTS] == batch.tolist()
        first.append(batch.tolist())
    a.reset()
    assert [a.act_batch(obs[t][None])[0].tolist() for t in range(40)] == first
    # two lock-step episodes of the same team act as two separate runs
    both = np.stack([obs, obs[::-1]], axis=1)  # (T, 2, R, 7)
    a.reset(2)
    b.reset()
    for t in range(40):
        acts = a.act_batch(both[t])
        assert acts[0].tolist() == first[t]
        assert acts[1].tolist() == b.act_batch(both[t, 1][None])[0].tolist()
    with pytest.raises(ValueError, match="one episode"):
        a.act({AGENTS[0]: obs[0, 0]})
    with pytest.raises(ValueError, match="shape"):
        a.act_batch(obs[0])
