"""A short PPO run must learn (beat a random team), and the CLI's train -> eval -> compare chain must work.

Episodes are shortened to 300 ticks (signal at 150) so a run of 100k robot-steps (~110 team episodes) fits in
~15 s; a fixed seed makes the outcome reproducible.  On this short task a random team scores ~0.085 and a
team that always drives forward ~0.21 (reflex on), so a policy has to shift most of its probability mass to
useful actions to pass.  We score the *sampled* (stochastic) policy over 32 episodes because the untrained
policy's greedy action can already be "forward" by chance; the sampled policy starts as a random team.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

from baselines.cli import main  # noqa: E402
from baselines.evaluate import evaluate_run  # noqa: E402
from baselines.protocols import run_protocol  # noqa: E402
from baselines.sb3.train import TrainConfig, load_config  # noqa: E402
from mahn_envs.core.params import TaskParams  # noqa: E402

SHORT = ["--max-cycles", "300", "--signal-tick", "150", "--n-episodes", "16", "--reward-scale", "100"]
#: short-task settings: a 300-tick episode wants gamma 0.99; its team fitness is ~0.2, so reward x100 brings
#: returns to the O(10) range the value net learns well (the full task uses x0.1 for fitnesses of 1..170)
SHORT_HP = '{"n_steps": 128, "batch_size": 1024, "gamma": 0.99, "learning_rate": 1e-3, "ent_coef": 0.0}'


class RandomTeam:
    """Uniform random actions: the baseline a learner must beat."""

    def __init__(self, seed: int) -> None:
        self.seed = seed

    def reset(self, n_episodes: int = 1) -> None:
        self.rng = np.random.default_rng(self.seed)

    def act_batch(self, obs: np.ndarray) -> np.ndarray:
        return self.rng.integers(0, 3, obs.shape[:2])


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("ppo")
    assert main(["train", "--algo", "ppo", "--steps", "100000", "--seed", "0", "--out", str(out), *SHORT,
                 "--eval-every", "25000", "--hyperparams", SHORT_HP]) == 0
    return out


def test_short_ppo_beats_random(ppo_run) -> None:
    params = TaskParams(max_cycles=300, signal_tick=150)
    random_fit = run_protocol("training", RandomTeam(1), "plus", params, episodes=32, seed=1).summary()["fitness"]
    res = evaluate_run(ppo_run, maps=["plus"], protocols=["training"], episodes=32, seed=1, which="final",
                       stochastic=True, write=False)
    learned = res["protocols"]["training"]["plus"]["fitness"]
    # seeds 0, 1, 2 reach 0.173, 0.173, 0.102 against random's 0.085 (seed 0 is the one tested)
    assert learned > 1.5 * random_fit, (learned, random_fit)
    greedy = evaluate_run(ppo_run, maps=["plus"], protocols=["training"], write=False)
    assert greedy["protocols"]["training"]["plus"]["fitness"] > random_fit


def test_run_directory_contents(ppo_run) -> None:
    for name in ("config.json", "eval_log.csv", "model.zip", "best_model.zip", "summary.json"):
        assert (ppo_run / name).exists(), name
    assert any((ppo_run / "tb").rglob("events.out.tfevents.*"))
    cfg = load_config(ppo_run)
    assert cfg.max_cycles == 300 and cfg.hyperparams == json.loads(SHORT_HP)
    summary = json.loads((ppo_run / "summary.json").read_text())
    assert summary["steps"] >= 60000 and set(summary["best"]) == {
        "fitness_plus", "solved_plus", "fitness_asymmetric_plus", "solved_asymmetric_plus"}


def test_cli_eval_both_maps_and_protocol_report(ppo_run, capsys) -> None:
    assert main(["eval", str(ppo_run), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    training = res["protocols"]["training"]
    assert set(training) == {"plus", "asymmetric_plus"}
    assert all({"fitness", "solved"} <= set(v) for v in training.values())
    seq = res["protocols"]["sequential"]  # the real-world protocol, through mahn_evo.evaluation.protocols
    assert "error" not in seq and set(seq) == {"plus", "asymmetric_plus"}
    assert all({"fitness", "solved"} <= set(v) for v in seq.values())


@pytest.mark.parametrize("algo,hp", [("recurrent_ppo", '{"n_steps": 32, "batch_size": 256, "n_epochs": 2}'),
                                     ("dqn", '{"learning_starts": 500, "gradient_steps": 1}')])
def test_other_algorithms_train_and_evaluate(tmp_path, algo, hp) -> None:
    out = tmp_path / algo
    assert main(["train", "--algo", algo, "--steps", "3000", "--seed", "0", "--out", str(out), "--max-cycles",
                 "60", "--signal-tick", "30", "--n-episodes", "4", "--hyperparams", hp]) == 0
    res = evaluate_run(out, protocols=["training"], write=False)
    assert np.isfinite(res["protocols"]["training"]["plus"]["fitness"])


def test_bad_config_is_rejected() -> None:
    with pytest.raises(ValueError, match="unknown algorithm"):
        TrainConfig(algo="a2c", steps=10)
    with pytest.raises(SystemExit):
        main(["train", "--algo", "ppo", "--steps", "10", "--out", "x", "--hyperparams", "[1]"])


def test_a_budget_below_one_episode_per_slot_is_refused(tmp_path, capsys) -> None:
    """Fewer robot-steps than one full episode in every slot: no episode ends, so "best" would be the untrained
    policy.  Refused before anything is written."""
    out = tmp_path / "short"
    args = ["train", "--algo", "ppo", "--seed", "0", "--out", str(out), "--max-cycles", "60", "--signal-tick", "30",
            "--n-episodes", "4"]
    assert main([*args, "--steps", "719"]) == 2  # 60 ticks x 4 episodes x 3 robots = 720
    assert "at least one full episode per slot" in capsys.readouterr().err and not out.exists()
    cfg = TrainConfig(algo="ppo", steps=720, max_cycles=60, signal_tick=30, n_episodes=4)
    cfg.check_budget()
