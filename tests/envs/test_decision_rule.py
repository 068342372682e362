"""The "net_input" decision rule: winner-take-all on the outputs' net inputs instead of their float32 sigmoids.

It must be one rule everywhere a team runs (the trainer's packed kernel, the scalar network of the env and the
robots), give the original's action whenever the sigmoids differ, break the saturation ties the sigmoids make,
and travel with the team in its file.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numba import njit

from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.core.controller import _sigmoid, network_action, transposed, winner_take_all
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.evaluation.margins import decision_margins
from mahn_evo.evaluation.task_setup import task_env
from mahn_evo.training.champion import Champion

from .helpers import random_team
from .test_kernel_identity import packed_network

PUBLISHED = Path(__file__).parents[2] / "docs" / "results" / "experiment_mahn_0.1" / "champions"
AGENTS = ["robot_0", "robot_1", "robot_2"]


@njit(error_model="numpy")
def reference_net_decision(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp):
    """Two synchronous steps written plainly (as tests/envs/test_kernel_identity.py's reference), deciding by the
    outputs' net inputs (sum + bias) of the second step."""
    n_hidden = wt_hh.shape[3]
    wanted = 1 if (wt_ih.shape[2] == 2 and rflag_signal != 0) else 0
    if wanted != brain[b, r]:
        brain[b, r] = wanted
        hid[b, r, :] = 0.0
        out[b, r, :] = 0.0
    k = brain[b, r]
    net = np.zeros(3, np.float32)
    for _ in range(2):
        for q in range(3):
            acc = np.float32(0.0)
            for m in range(n_hidden):
                acc += wt_ho[b, r, k, m, q] * hid[b, r, m]
            net[q] = acc + b_o[b, r, k, q]
        for i in range(n_hidden):
            acc = np.float32(0.0)
            for j in range(wt_ih.shape[3]):
                acc += wt_ih[b, r, k, j, i] * obs[b, r, j]
            for m in range(n_hidden):
                acc += wt_hh[b, r, k, m, i] * hid[b, r, m]
            tmp[i] = acc
        for q in range(3):
            out[b, r, q] = _sigmoid(net[q])
        for i in range(n_hidden):
            hid[b, r, i] = _sigmoid(tmp[i] + b_h[b, r, k, i])
    return winner_take_all(net[0], net[1], net[2])


def _packed(by_net):
    def run(*args):
        return packed_network(*args, by_net)
    return run


def _scalar(by_net):
    def run(*args):
        return network_action(*args, by_net)
    return run


def _run(fn, weights, obs_seq, sig_seq):
    T, B, R = obs_seq.shape[:3]
    hid = np.zeros((B, R, 9), np.float32)
    out = np.zeros((B, R, 3), np.float32)
    brain = np.zeros((B, R), np.int64)
    tmp = np.zeros(12, np.float32)
    acts, outs, hids = [], [], []
    for t in range(T):
        obs = np.ascontiguousarray(obs_seq[t])
        for b in range(B):
            for r in range(R):
                acts.append(fn(b, r, obs, sig_seq[t, b, r], *weights, hid, out, brain, tmp))
                outs.append(out[b, r].copy())
        hids.append(hid.copy())
    return np.array(acts), np.array(outs), np.array(hids)


def _inputs(seed, T=120, B=6):
    rng = np.random.default_rng(seed)
    obs_seq = rng.uniform(-0.2, 1.0, (T, B, 3, 7)).astype(np.float32)
    obs_seq[:, :, :, :6][obs_seq[:, :, :, :6] < 0.25] = 0.0
    sig_seq = np.zeros((T, B, 3), np.int64)
    sig_seq[60:] = 1
    obs_seq[:, :, :, 6] = sig_seq
    return obs_seq, sig_seq


@pytest.mark.parametrize("brains", [1, 2])
def test_every_path_decides_by_the_same_net_inputs(brains):
    """Saturating weights (scale 6): the scalar network and the trainer's packed kernel both give the reference's
    net-input decisions, with their states bit-identical to the original rule's (the rule reads, never writes)."""
    teams = TeamControllers.stack([random_team(s + 7, n_brains=brains, scale=6.0) for s in range(6)])
    weights = transposed(teams)
    obs_seq, sig_seq = _inputs(brains)
    ref = _run(reference_net_decision, weights, obs_seq, sig_seq)
    for fn in (_scalar(True), _packed(True)):
        got = _run(fn, weights, obs_seq, sig_seq)
        assert np.array_equal(got[0], ref[0])
        assert np.array_equal(got[1], ref[1]) and np.array_equal(got[2], ref[2])
    original = _run(_scalar(False), weights, obs_seq, sig_seq)
    assert np.array_equal(original[1], ref[1]) and np.array_equal(original[2], ref[2])
    # the rules differ exactly where the top outputs tie, and there the net inputs decide
    outs = ref[1]
    top = np.sort(outs, axis=1)
    tied = top[:, 2] == top[:, 1]
    assert tied.sum() > 50  # saturated ties are common at this scale
    assert np.array_equal(original[0][~tied], ref[0][~tied])
    assert np.any(original[0][tied] != ref[0][tied])


def test_a_saturated_tie_goes_to_the_output_driven_hardest():
    """Outputs left and right both saturate to 1.0f; the original's rule takes left (left beats right in a tie),
    net_input takes right, whose net input is larger."""
    R, K = 3, 1
    w_ih = np.zeros((R, K, 9, 7))
    b_h = np.full((R, K, 9), 2.0)  # hidden nodes sit near 1.0
    w_ho = np.zeros((R, K, 3, 9))
    w_ho[:, :, 0, :] = 2.0  # left: net input 18 * h
    w_ho[:, :, 2, :] = 3.0  # right: net input 27 * h
    team = TeamControllers(w_ih, np.zeros((R, K, 9, 9)), w_ho, b_h, np.zeros((R, K, 3)))
    obs = {a: np.zeros(7, np.float32) for a in AGENTS}
    for decision, want in (("output", 0), ("net_input", 2)):
        policy = ControllerPolicy(team.with_decision(decision), AGENTS)
        actions = policy.act(obs)
        assert policy.outputs[0, 0] == policy.outputs[0, 2] == np.float32(1.0)
        assert set(actions.values()) == {want}
    net = ControllerPolicy(team.with_decision("net_input"), AGENTS)
    net.act(obs)
    assert net.decision_values[0, 2] > net.decision_values[0, 0] > 17.0


def test_the_trainer_kernel_and_the_env_agree_under_net_input():
    """A published champion, switched to net_input: the batch core's episode (actions tick by tick) equals the
    PettingZoo env driven by ControllerPolicy, and the two rules give different episodes (the team had ties)."""
    champ = Champion.load(PUBLISHED / "situational_s012.json")
    team = champ.controllers.with_decision("net_input")
    res = BatchSim("plus", 1).run_controllers(team, record=True)
    env = task_env("plus", TaskParams())
    try:
        obs, _ = env.reset(seed=0)
        policy = ControllerPolicy(team, env.possible_agents)
        actions = []
        while env.agents:
            act = policy.act(obs)
            actions.append([act[a] for a in env.possible_agents])
            obs, _, _, _, infos = env.step(act)
    finally:
        env.close()
    assert np.array_equal(res.trajectories[0, 1:, :, 3], np.array(actions, dtype=float))
    assert res.fitness[0] == pytest.approx(infos[env.possible_agents[0]]["team_fitness"], abs=1e-9)
    original = BatchSim("plus", 1).run_controllers(champ.controllers, record=True)
    assert not np.array_equal(original.trajectories, res.trajectories)


def test_net_input_removes_the_exact_ties_that_margins_report():
    champ = Champion.load(PUBLISHED / "situational_s012.json")
    before = decision_margins(champ)
    champ.controllers = champ.controllers.with_decision("net_input")
    after = decision_margins(champ)
    assert before["decision"] == "output" and after["decision"] == "net_input"
    assert before["tied_fraction"] > 0.05
    assert after["tied_fraction"] < before["tied_fraction"] / 10


def test_the_decision_travels_with_the_team_in_its_file():
    team = random_team(1).with_decision("net_input")
    data = team.to_dict()
    assert data["decision"] == "net_input"
    back = TeamControllers.from_dict(data)
    assert back.decision == "net_input" and np.array_equal(back.w_ho, team.w_ho)
    assert back.as_batch().decision == back.repeated(3).decision == back.repeated(3).team(2).decision == "net_input"
    del data["decision"]  # files written before the rule existed decide by the outputs
    assert TeamControllers.from_dict(data).decision == "output"
    with pytest.raises(ValueError, match="'decision' must be one of"):
        TeamControllers.from_dict({**data, "decision": "argmax"})
    with pytest.raises(ValueError, match="different rules"):
        TeamControllers.stack([random_team(1), random_team(2).with_decision("net_input")])


def test_a_run_trained_with_net_input_keeps_the_rule_in_its_champion_and_config(tmp_path):
    """`mahn-evo train --decision net_input`: the champion file carries the rule, the env replays its exact
    fitness through it, and resuming the run keeps it (config.json)."""
    from mahn_evo.cli import main
    from mahn_evo.storage.files import read_versioned_json
    from mahn_evo.training.config import EvolutionConfig

    out = tmp_path / "run"
    assert main(["train", "--mode", "situational", "--generations", "3", "--pop", "24", "--seed", "5",
                 "--decision", "net_input", "--out", str(out)]) == 0
    config = EvolutionConfig.from_saved(read_versioned_json(out / "config.json", "config"))
    assert config.decision == "net_input"
    champ = Champion.load(out / "champion.json")
    assert champ.controllers.decision == "net_input"
    env = task_env("plus", TaskParams())
    try:
        obs, _ = env.reset(seed=0)
        policy = ControllerPolicy(champ.controllers, env.possible_agents)
        while env.agents:
            obs, _, _, _, infos = env.step(policy.act(obs))
    finally:
        env.close()
    assert infos["robot_0"]["team_fitness"] == pytest.approx(champ.fitness, abs=1e-9)
    with pytest.raises(ValueError, match="decision must be one of"):
        EvolutionConfig(decision="argmax")
