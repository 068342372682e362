"""Settings of the lean PPO family (numpy only, so configs are read and checked without torch).

Three methods share one loop (`baselines/lean/ppo.py`), parameter sharing with the agent index in the input and
the same 7 sensor inputs for the actor as the evolved controllers:

- `ippo_gru`: IPPO, a GRU actor and a GRU critic that sees the robot's inputs plus the time;
- `mappo_gru`: MAPPO, the same GRU actor and a centralised feed-forward critic on the team's state
  (`PatrolReturnVecEnv.global_state`: time, poses, signals, post coverage, return credit, team flags);
- `ppo_ff`: feed-forward PPO on the last `frame_stack` observations, the memoryless control (critic: the same
  stack plus the time).

Why these defaults (the task: 1364-tick episodes of fixed, known length; the team fitness is the sum of the
rewards; the signal at tick 690 must be linked to whatever the robots did before it):
- rollouts are whole episodes, all slots from tick 0 to the end, so every update sees every tick of every
  episode (no fixed window of each episode per update);
- the episode end is a termination, not a truncation: the horizon is fixed, the return after the last tick
  is 0, and the critics see the time, so nothing is bootstrapped at tick 1364;
- gamma = 1: with a fixed horizon the undiscounted return is finite and *is* the remaining team fitness, so the
  objective is exactly the paper's score and a reward at tick 1300 weighs as much as one at tick 10;
- lambda = 1: the advantage is the whole return-to-go minus the (time-aware) critic's baseline, so credit
  reaches across all 1364 ticks and no untrained critic biases it.  Measured on the full task (ppo_ff,
  32 episodes per update, seed 0): lambda 0.99 drove the policy into turning left and the team fitness from
  1.15 to 0.49 within 4 updates, 0.999 dipped to 0.79 before recovering, 1.0 rose steadily to 1.26 in 10
  updates; optuna searches 0.95-1.0 (`baselines/lean/tune.py`);
- truncated BPTT over chunks of `bptt` = 682 ticks (half an episode, > 256) from hidden states stored during
  the rollout: a chunk boundary at tick 682 falls just before the signal, and the stored state carries what
  the robot did before; `bptt` = 1364 backpropagates through whole episodes at ~1.3x the update cost;
- rewards x 0.1 (team fitness 1..170 -> returns 0.1..17, value targets in a range default learning rates
  handle); advantages normalised per minibatch.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

from mahn_envs.core.params import TaskParams

from ..io import settings_from_dict

METHODS = ("ippo_gru", "mappo_gru", "ppo_ff")
RECURRENT_METHODS = ("ippo_gru", "mappo_gru")
EVAL_MAPS = ("plus", "asymmetric_plus")
MIN_BPTT = 256
#: settings that only decide when a run stops or how often it reports; they may change on resume
STOPPING_RULES = ("steps", "eval_every", "checkpoint_every")


@dataclass
class LeanConfig:
    """One run of a lean PPO method.  `max_cycles` / `signal_tick` shorten episodes for tests only."""

    method: str
    steps: int  #: budget in robot-steps (one robot for one tick); rounded up to whole updates
    seed: int = 0
    map: str = "plus"
    n_episodes: int = 32  #: episodes per rollout (slots = x robots); one rollout = whole episodes
    max_cycles: int = 1364
    signal_tick: int = 690
    reward_scale: float = 0.1
    gamma: float = 1.0
    gae_lambda: float = 1.0
    lr: float = 3e-4
    epochs: int = 4
    minibatches: int = 2  #: per epoch; 2 halves the sequential GRU passes of 4 (MAPPO uses 1)
    clip: float = 0.2
    ent_coef: float = 0.01
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    hidden: int = 64
    bptt: int = 682  #: ticks per truncated-BPTT chunk (recurrent methods)
    frame_stack: int = 4  #: observations stacked for ppo_ff
    eval_every: int = 0  #: updates between greedy evaluations (0 = every update)
    eval_maps: Sequence[str] = EVAL_MAPS
    checkpoint_every: int = 1  #: updates between checkpoints
    torch_threads: int = 1

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        for name in ("steps", "n_episodes", "max_cycles", "epochs", "minibatches", "hidden", "bptt",
                     "frame_stack", "checkpoint_every", "torch_threads"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"{name} must be a positive integer, got {v!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {self.seed!r}")
        if self.eval_every < 0:
            raise ValueError(f"eval_every must be >= 0, got {self.eval_every!r}")
        if not 0.0 < self.gamma <= 1.0:
            raise ValueError(f"gamma must be in (0, 1], got {self.gamma!r}")
        if not 0.0 <= self.gae_lambda <= 1.0:
            raise ValueError(f"gae_lambda must be in [0, 1], got {self.gae_lambda!r}")
        for name in ("lr", "clip", "reward_scale", "max_grad_norm"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")
        for name in ("ent_coef", "vf_coef"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if self.bptt < min(MIN_BPTT, self.max_cycles):
            raise ValueError(f"bptt must be at least {MIN_BPTT} ticks (or the whole episode), got {self.bptt}")
        self.eval_maps = list(self.eval_maps)
        _ = self.task_params  # validates max_cycles / signal_tick

    @property
    def recurrent(self) -> bool:
        return self.method in RECURRENT_METHODS

    @property
    def task_params(self) -> TaskParams:
        return TaskParams(max_cycles=self.max_cycles, signal_tick=self.signal_tick)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["algo"] = self.method  # the key `baselines.comparison.compare` names a run's method by
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> LeanConfig:
        return settings_from_dict(cls, d, "lean PPO", derived=("algo",))

    def with_overrides(self, overrides: dict[str, Any]) -> LeanConfig:
        d = {k: v for k, v in asdict(self).items()}
        unknown = set(overrides) - set(d)
        if unknown:
            raise ValueError(f"unknown lean PPO setting(s) {sorted(unknown)}; known: {sorted(d)}")
        d.update(overrides)
        return LeanConfig(**d)
