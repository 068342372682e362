"""The lean PPO methods: they learn (beat a random team), the GRU carries state, runs resume bit-identically."""
from __future__ import annotations

import json

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from baselines.lean.config import LeanConfig  # noqa: E402
from baselines.lean.nets import GRUNet, LeanTeamPolicy, stack_frames  # noqa: E402
from baselines.lean.ppo import LeanPPO, gae, load_actor, train  # noqa: E402
from baselines.lean.weights_npz import load_weights  # noqa: E402
from mahn_envs.core.batch import BatchSim  # noqa: E402
from mahn_envs.core.params import TaskParams  # noqa: E402

# a 300-tick task (signal at 150): a random team scores 0.086, one that always drives forward 0.214
SHORT = dict(max_cycles=300, signal_tick=150)
# tiny budgets that learn: 16 episodes per update, rewards x 10 (returns of ~1 at this short task's fitness)
TINY = dict(**SHORT, n_episodes=16, bptt=300, hidden=32, lr=3e-3, epochs=4, minibatches=2, reward_scale=10.0,
            eval_maps=["plus"])


def random_team_fitness(episodes: int = 64) -> float:
    return float(BatchSim("plus", episodes, TaskParams(**SHORT)).run_random(seed=0).fitness.mean())


@pytest.mark.parametrize("method", ["ppo_ff", "mappo_gru", "ippo_gru"])
def test_a_short_run_beats_a_random_team(tmp_path, method):
    """8 updates (115k robot-steps), seed 0: the sampling policy's team fitness rises above a random team's
    (measured: ppo_ff 0.151, mappo_gru 0.138, ippo_gru 0.152 against 0.086 in the last update)."""
    cfg = LeanConfig(method=method, steps=8 * 16 * 3 * 300, seed=0, eval_every=8, **TINY)
    summary = train(cfg, tmp_path / "run")
    rows = json.loads((tmp_path / "run" / "checkpoint.json").read_text())["train_rows"]
    random_fitness = random_team_fitness()
    assert rows[0]["fitness_mean"] < 1.1 * random_fitness  # it starts as a random team
    assert rows[-1]["fitness_mean"] > 1.2 * random_fitness
    assert summary["steps"] == 8 * 16 * 3 * 300 and summary["algo"] == method


def test_the_recurrent_actor_carries_state_across_ticks():
    torch.manual_seed(0)
    actor = GRUNet(10, 16, 3, 1.0)
    obs = torch.rand(1, 4, 10)
    h0 = actor.initial_state(4)
    logits0, h1 = actor(obs, h0)
    logits1, _ = actor(obs, h1)  # the same observation, another hidden state
    assert not torch.allclose(torch.softmax(logits0, -1), torch.softmax(logits1, -1), atol=1e-4)
    # the team policy passes its hidden state on from one call to the next, and reset clears it
    policy = LeanTeamPolicy(actor, "ippo_gru", n_robots=3)
    policy.reset(1)
    x = np.random.default_rng(0).random((1, 3, 7)).astype(np.float32)
    policy.act_batch(x)
    h_after_one = policy._h.clone()
    policy.act_batch(x)
    assert not torch.equal(policy._h, h_after_one)
    policy.reset(1)
    assert torch.count_nonzero(policy._h) == 0


def test_the_rollout_stores_the_hidden_state_it_carried(tmp_path):
    """The state stored at a BPTT chunk start is what the actor reaches by playing the chunk before it."""
    cfg = LeanConfig(method="ippo_gru", steps=1, **{**TINY, "bptt": 256, "n_episodes": 2})
    run = LeanPPO(cfg, tmp_path / "run")
    buf = run.rollout()
    assert np.count_nonzero(buf.h_actor[0]) == 0 and np.count_nonzero(buf.h_actor[1]) > 0
    with torch.no_grad():
        _, h = run.actor(torch.from_numpy(buf.obs[:256]), run.actor.initial_state(run.N))
    np.testing.assert_allclose(buf.h_actor[1], h[0].numpy(), rtol=1e-5, atol=1e-6)
    # and the critic's too (IPPO: a GRU over the inputs and the time)
    assert np.count_nonzero(buf.h_critic[1]) > 0


def test_mappo_critic_sees_the_global_state(tmp_path):
    cfg = LeanConfig(method="mappo_gru", steps=1, **{**TINY, "n_episodes": 2})
    run = LeanPPO(cfg, tmp_path / "run")
    buf = run.rollout()
    assert buf.values.shape == (300, 2)  # one value per team
    np.testing.assert_allclose(buf.gstate[:, 0, 0], np.arange(300) / 300, rtol=1e-6)  # the time column
    assert np.all(buf.gstate[200, :, -1] == 1.0)  # signal given (tick 150)


def test_gae_terminates_at_the_fixed_horizon():
    rewards = np.array([[1.0], [0.0], [2.0]], dtype=np.float32)
    values = np.array([[0.5], [0.5], [0.5]], dtype=np.float32)
    adv, ret = gae(rewards, values, gamma=1.0, lam=1.0)
    np.testing.assert_allclose(ret[:, 0], [3.0, 2.0, 2.0])  # reward-to-go, nothing bootstrapped after the end
    adv, ret = gae(rewards, values, gamma=1.0, lam=0.0)
    np.testing.assert_allclose(ret[:, 0], [1.5, 0.5, 2.0])


def test_frame_stack_matches_the_rollouts_rolling_stack():
    obs = np.arange(2 * 3 * 4 * 1, dtype=np.float32).reshape(4, 3, 2)
    s = stack_frames(obs, 3)
    np.testing.assert_array_equal(s[2, 0], np.concatenate([obs[2, 0], obs[1, 0], obs[0, 0]]))
    np.testing.assert_array_equal(s[1, 0], np.concatenate([obs[1, 0], obs[0, 0], np.zeros(2)]))


@pytest.mark.parametrize("method", ["ippo_gru", "ppo_ff"])
def test_resume_continues_bit_identically(tmp_path, method):
    base = dict(method=method, seed=3, max_cycles=60, signal_tick=30, n_episodes=2, bptt=60, hidden=8,
                eval_maps=["plus"])
    per_update = 2 * 3 * 60
    train(LeanConfig(steps=3 * per_update, **base), tmp_path / "straight")
    train(LeanConfig(steps=1 * per_update, **base), tmp_path / "resumed")
    train(LeanConfig(steps=3 * per_update, **base), tmp_path / "resumed", resume=True)
    a = json.loads((tmp_path / "straight" / "checkpoint.json").read_text())
    b = json.loads((tmp_path / "resumed" / "checkpoint.json").read_text())
    assert a["update"] == b["update"] == 3 and a["rng"] == b["rng"] and a["best_sampled"] == b["best_sampled"]
    timing = ("wall_time", "cpu_seconds", "robot_steps_per_second")
    def strip(rows):
        return [{k: v for k, v in r.items() if k not in timing} for r in rows]
    assert strip(a["train_rows"]) == strip(b["train_rows"])
    wa = load_weights(tmp_path / "straight" / a["weights"])
    wb = load_weights(tmp_path / "resumed" / b["weights"])
    for part in ("actor", "critic"):
        for k in wa[part]:
            assert torch.equal(wa[part][k], wb[part][k]), (part, k)
    for index, state in wa["optim"]["state"].items():  # Adam's moments and step counts too
        for k, value in state.items():
            assert torch.equal(value, wb["optim"]["state"][index][k]), ("optim", index, k)
    assert len(list((tmp_path / "resumed").glob("checkpoint_u*.npz"))) == 1  # old weights removed
    with np.load(tmp_path / "resumed" / b["weights"], allow_pickle=False) as f:  # plain arrays, no pickle
        assert "actor/" + next(iter(wa["actor"])) in f.files
    cfg, actor = load_actor(tmp_path / "resumed", "final")
    assert cfg.method == method


def test_resume_refuses_other_settings_and_damaged_weights(tmp_path):
    base = dict(method="ppo_ff", seed=0, max_cycles=60, signal_tick=30, n_episodes=2, bptt=60, hidden=8,
                eval_maps=["plus"])
    train(LeanConfig(steps=360, **base), tmp_path / "run")
    with pytest.raises(ValueError, match="lr"):
        LeanPPO(LeanConfig(steps=720, **{**base, "lr": 1e-3}), tmp_path / "run", resume=True)
    with pytest.raises(ValueError, match="already holds a run"):
        LeanPPO(LeanConfig(steps=720, **base), tmp_path / "run")
    ck = json.loads((tmp_path / "run" / "checkpoint.json").read_text())
    (tmp_path / "run" / ck["weights"]).write_bytes(b"not a weights file")
    with pytest.raises(ValueError, match="damaged"):
        LeanPPO(LeanConfig(steps=720, **base), tmp_path / "run", resume=True)


def test_config_rejects_bad_settings():
    with pytest.raises(ValueError, match="method"):
        LeanConfig(method="dqn", steps=1)
    with pytest.raises(ValueError, match="bptt"):
        LeanConfig(method="ippo_gru", steps=1, bptt=128)
    with pytest.raises(ValueError, match="gamma"):
        LeanConfig(method="ppo_ff", steps=1, gamma=0.0)
    with pytest.raises(ValueError, match="unknown"):
        LeanConfig.from_dict({"method": "ppo_ff", "steps": 1, "colour": 3})


def test_cli_lean_starts_then_resumes_with_one_command(tmp_path, capsys):
    from baselines.cli import main

    args = ["lean", "--method", "ppo_ff", "--seed", "1", "--out", str(tmp_path / "run"), "--resume",
            "--max-cycles", "60", "--signal-tick", "30", "--hyperparams", '{"n_episodes": 2, "hidden": 8}']
    assert main(args[:3] + ["--steps", "360"] + args[3:]) == 0  # no run there yet: starts it
    assert main(args[:3] + ["--steps", "7.2e2"] + args[3:]) == 0  # continues it to 2 updates
    out = capsys.readouterr().out
    assert '"steps": 720' in out
    assert main(["lean", "--method", "ppo_ff", "--steps", "360", "--out", str(tmp_path / "x"),
                 "--hyperparams", '{"colour": 1}']) == 2


def test_resume_names_a_checkpoint_with_missing_fields(tmp_path):
    base = dict(method="ppo_ff", seed=0, max_cycles=60, signal_tick=30, n_episodes=2, bptt=60, hidden=8,
                eval_maps=["plus"])
    train(LeanConfig(steps=360, **base), tmp_path / "run")
    path = tmp_path / "run" / "checkpoint.json"
    data = json.loads(path.read_text())
    del data["value_norm"]
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="checkpoint.json.*value_norm"):
        LeanPPO(LeanConfig(steps=720, **base), tmp_path / "run", resume=True)


def test_eval_scores_a_lean_run_with_the_shared_protocols(tmp_path):
    from baselines.evaluate import evaluate_run

    base = dict(method="ippo_gru", seed=0, max_cycles=60, signal_tick=30, n_episodes=2, bptt=60, hidden=8,
                eval_maps=["plus"])
    train(LeanConfig(steps=360, **base), tmp_path / "run")
    res = evaluate_run(tmp_path / "run", maps=["plus"], protocols=["training"], which="best")
    best = json.loads((tmp_path / "run" / "best.json").read_text())["evaluation"]["fitness_plus"]
    assert res["algo"] == "ippo_gru" and res["recurrent"]
    assert res["protocols"]["training"]["plus"]["fitness"] == pytest.approx(best, abs=1e-6)
    assert (tmp_path / "run" / "eval.json").exists()


def test_the_best_sampled_actor_is_the_one_that_played_its_rollout(tmp_path):
    """best_sampled_actor.npz holds the weights that played the best-scoring rollout, i.e. those of the run after
    one update fewer (training is deterministic), and survives a resume from a checkpoint that predates it."""
    from baselines.evaluate import evaluate_run

    base = dict(method="ppo_ff", seed=2, max_cycles=60, signal_tick=30, n_episodes=2, hidden=8, lr=3e-3,
                eval_maps=["plus"])
    per_update = 2 * 3 * 60
    train(LeanConfig(steps=4 * per_update, **base), tmp_path / "run")
    rows = json.loads((tmp_path / "run" / "checkpoint.json").read_text())["train_rows"]
    k = max(range(len(rows)), key=lambda i: rows[i]["fitness_mean"])  # first best: its update is k + 1
    kept = json.loads((tmp_path / "run" / "best_sampled.json").read_text())
    assert kept["update"] == k + 1 and kept["fitness_mean"] == pytest.approx(rows[k]["fitness_mean"], abs=1e-6)
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["best_sampled"]["steps"] == kept["steps"] == (k + 1) * per_update
    again = summary["best_sampled_evaluation"]  # that actor on 20 fresh sampled episodes of each eval map
    assert again["episodes"] == 20 and set(again) == {"episodes", "plus"} and 0.0 <= again["plus"]["solved_rate"] <= 1
    assert again["plus"]["fitness"] > 0.0
    if k == 0:
        before = LeanPPO(LeanConfig(steps=per_update, **base), tmp_path / "before").actor.state_dict()
    else:
        train(LeanConfig(steps=k * per_update, **base), tmp_path / "before")
        before = load_actor(tmp_path / "before", "final")[1].state_dict()
    sampled = load_actor(tmp_path / "run", "best_sampled")[1].state_dict()
    for name, value in before.items():
        assert torch.equal(value, sampled[name]), name
    res = evaluate_run(tmp_path / "run", maps=["plus"], protocols=["training"], episodes=4, which="best_sampled",
                       stochastic=True, write=False)
    assert res["model"] == "best_sampled_actor.npz" and not res["deterministic"]
    from baselines.cli import main

    assert main(["eval", str(tmp_path / "run"), "--model", "best_sampled", "--stochastic", "--protocols", "training",
                 "--maps", "plus", "--episodes", "2"]) == 0
    assert json.loads((tmp_path / "run" / "eval.json").read_text())["model"] == "best_sampled_actor.npz"
    # a checkpoint written before the field: resumed, the best sampled actor is kept from there on
    path = tmp_path / "run" / "checkpoint.json"
    data = json.loads(path.read_text())
    del data["best_sampled"]
    path.write_text(json.dumps(data))
    (tmp_path / "run" / "best_sampled_actor.npz").unlink()
    train(LeanConfig(steps=5 * per_update, **base), tmp_path / "run", resume=True)
    assert json.loads((tmp_path / "run" / "best_sampled.json").read_text())["update"] == 5
    assert (tmp_path / "run" / "best_sampled_actor.npz").exists()
    with pytest.raises(FileNotFoundError, match="best_sampled_actor.npz"):
        (tmp_path / "run" / "best_sampled_actor.npz").unlink()
        load_actor(tmp_path / "run", "best_sampled")
