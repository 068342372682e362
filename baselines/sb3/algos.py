"""The three RL methods and their hyper-parameters (one place, so runs, docs and the comparison agree).

All use parameter sharing: one policy acts for every slot of `PatrolReturnVecEnv` (every robot of every
episode), told apart only by the one-hot agent index in the observation.  Why these values:

* Episodes are long (1364 ticks) and the task's credit is delayed: patrol credit is sampled every 30 ticks,
  the signal comes at tick 690 and the +100 bonus only when every robot is home.  Hence a high discount
  (gamma = 0.999 for the policy-gradient methods, an effective horizon of ~1000 ticks) and GAE(0.95).
* Rewards are the team fitness increments scaled by `reward_scale` = 0.1 (set in `TrainConfig`): unsolved
  teams score ~1..70 and solved ones 100..170, so returns stay O(0.1..17), a range the value net fits without
  its loss swamping the policy's share of SB3's global gradient clipping (0.5).  Short runs showed the scale
  matters: with returns ~0.002 (x0.01 on a 300-tick task) PPO did not beat a random team on 2 of 3 seeds.
* 16 lock-stepped episodes x 3 robots = 48 slots.  PPO collects 48 x 512 = 24,576 robot-steps per update
  (18 episodes' worth), enough to average over the deterministic task's policy noise; RecurrentPPO uses shorter
  rollouts (256) because its sequential LSTM passes are the slow part.
* Entropy bonus 0.01 keeps the 3-way action distribution from collapsing to "always forward" (a local optimum:
  forward with the reflex already beats random) before the signal-dependent return is discovered.
* DQN uses gamma = 0.995 (one-step TD bootstrapping over a 0.999 horizon is slow and unstable), a 300k
  replay buffer (~73 team episodes of robot transitions) and 8 gradient steps per 4 vector steps (192
  transitions), i.e. a replay ratio of 1 sample in 24 x batch 256 ~ 10 uses per transition.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover - SB3 imports torch; the classes are imported lazily below
    from stable_baselines3.common.base_class import BaseAlgorithm

ALGO_NAMES = ("ppo", "recurrent_ppo", "dqn")


@dataclass(frozen=True)
class AlgoSpec:
    """How to build one method: its SB3 class (imported lazily: torch), policy and default hyper-parameters."""

    name: str
    policy: str
    hyperparams: dict[str, Any] = field(default_factory=dict)
    recurrent: bool = False

    def model_class(self) -> type[BaseAlgorithm]:
        if self.name == "ppo":
            from stable_baselines3 import PPO

            return PPO
        if self.name == "dqn":
            from stable_baselines3 import DQN

            return DQN
        from sb3_contrib import RecurrentPPO

        return RecurrentPPO


_MLP = {"net_arch": {"pi": [64, 64], "vf": [64, 64]}}

ALGOS: dict[str, AlgoSpec] = {
    "ppo": AlgoSpec("ppo", "MlpPolicy", {
        "learning_rate": 3e-4, "n_steps": 512, "batch_size": 2048, "n_epochs": 10, "gamma": 0.999,
        "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.01, "vf_coef": 0.5, "max_grad_norm": 0.5,
        "policy_kwargs": _MLP}),
    "recurrent_ppo": AlgoSpec("recurrent_ppo", "MlpLstmPolicy", {
        "learning_rate": 3e-4, "n_steps": 256, "batch_size": 2048, "n_epochs": 10, "gamma": 0.999,
        "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.01, "vf_coef": 0.5, "max_grad_norm": 0.5,
        "policy_kwargs": {"lstm_hidden_size": 64, "n_lstm_layers": 1, "net_arch": {"pi": [64], "vf": [64]}}},
        recurrent=True),
    "dqn": AlgoSpec("dqn", "MlpPolicy", {
        "learning_rate": 1e-4, "buffer_size": 300_000, "learning_starts": 20_000, "batch_size": 256,
        "gamma": 0.995, "train_freq": 4, "gradient_steps": 8, "target_update_interval": 10_000,
        "exploration_fraction": 0.2, "exploration_initial_eps": 1.0, "exploration_final_eps": 0.05,
        "max_grad_norm": 10.0, "policy_kwargs": {"net_arch": [64, 64]}}),
}


def get_algo(name: str) -> AlgoSpec:
    if name not in ALGOS:
        raise ValueError(f"unknown algorithm {name!r}; choose one of {list(ALGO_NAMES)}")
    return ALGOS[name]


def resolved_hyperparams(name: str, overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """Defaults with user overrides applied (unknown keys are left for SB3 to reject by name)."""
    hp = dict(get_algo(name).hyperparams)
    hp.update(overrides or {})
    return hp


def load_model(name: str, path: str, device: str = "cpu") -> Any:
    """Load a saved SB3 model zip of the given method."""
    return get_algo(name).model_class().load(path, device=device)
