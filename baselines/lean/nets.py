"""Networks of the lean PPO methods (torch): a GRU actor / critic, feed-forward actor / critics, and the greedy
team policy that evaluation protocols drive.

One GRU serves both the rollout (one tick at a time, hidden state carried) and the update (a chunk of ticks from
a stored hidden state), so what is trained is what acted: `nn.GRU`'s parameters, run by the compiled recurrence
of `gru_kernel` (the same code on both paths; 1.4-1.7x faster updates than `nn.GRU`'s own loop, docs/baselines.md).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from torch import nn

from mahn_envs.policies.team_policy import DictActFromBatch

from ..vec_env import N_SENSOR_INPUTS, slot_observations
from .config import LeanConfig
from .gru_kernel import gru_sequence

N_ACTIONS = 3


def _init(layer: nn.Linear, gain: float) -> nn.Linear:
    nn.init.orthogonal_(layer.weight, gain)
    nn.init.zeros_(layer.bias)
    return layer


class GRUNet(nn.Module):
    """Linear + tanh, a GRU, a linear head.  forward: x (L, N, in), h (1, N, H) -> (L, N, out), h."""

    def __init__(self, n_in: int, hidden: int, n_out: int, head_gain: float) -> None:
        super().__init__()
        self.hidden = hidden
        self.inp = _init(nn.Linear(n_in, hidden), np.sqrt(2))
        self.gru = nn.GRU(hidden, hidden)
        for name, p in self.gru.named_parameters():
            if "weight" in name:
                nn.init.orthogonal_(p)
            else:
                nn.init.zeros_(p)
        self.head = _init(nn.Linear(hidden, n_out), head_gain)

    def initial_state(self, n: int) -> torch.Tensor:
        return torch.zeros(1, n, self.hidden)

    def forward(self, x: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        y, h = gru_sequence(self.gru, torch.tanh(self.inp(x)), h)
        return self.head(y), h


class MLP(nn.Module):
    """Two tanh layers and a linear head."""

    def __init__(self, n_in: int, hidden: int, n_out: int, head_gain: float) -> None:
        super().__init__()
        self.net = nn.Sequential(_init(nn.Linear(n_in, hidden), np.sqrt(2)), nn.Tanh(),
                                 _init(nn.Linear(hidden, hidden), np.sqrt(2)), nn.Tanh(),
                                 _init(nn.Linear(hidden, n_out), head_gain))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


def actor_inputs(n_robots: int) -> int:
    """The actor's inputs per tick: the 7 sensor inputs and the one-hot agent index."""
    return N_SENSOR_INPUTS + n_robots


def build_networks(cfg: LeanConfig, n_robots: int, global_size: int) -> tuple[GRUNet | MLP, GRUNet | MLP]:
    """(actor, critic) of a method; weights drawn from torch's global generator (seeded by the caller)."""
    n_obs = actor_inputs(n_robots)
    if cfg.method == "ppo_ff":
        return (MLP(n_obs * cfg.frame_stack, cfg.hidden, N_ACTIONS, 0.01),
                MLP(n_obs * cfg.frame_stack + 1, cfg.hidden, 1, 1.0))
    actor = GRUNet(n_obs, cfg.hidden, N_ACTIONS, 0.01)
    if cfg.method == "ippo_gru":
        return actor, GRUNet(n_obs + 1, cfg.hidden, 1, 1.0)
    return actor, MLP(global_size, cfg.hidden, 1, 1.0)


def stack_frames(obs: np.ndarray, k: int) -> np.ndarray:
    """obs (T, N, D) -> (T, N, k*D): each tick with the k-1 before it (zeros before the episode start),
    newest first."""
    T, N, D = obs.shape
    out = np.zeros((T, N, k * D), dtype=np.float32)
    for j in range(k):
        out[j:, :, j * D:(j + 1) * D] = obs[:T - j]
    return out


class FrameStack:
    """The rolling stack of the last k observations of N slots (newest first), as `stack_frames` builds it."""

    def __init__(self, n: int, d: int, k: int) -> None:
        self.d, self.k = d, k
        self.buf = np.zeros((n, k * d), dtype=np.float32)

    def reset(self) -> None:
        self.buf[:] = 0.0

    def push(self, obs: np.ndarray) -> np.ndarray:
        self.buf[:, self.d:] = self.buf[:, :-self.d].copy()
        self.buf[:, :self.d] = obs
        return self.buf


class LeanTeamPolicy(DictActFromBatch):
    """A trained actor as a team policy (`reset(n_episodes)`, `act_batch(obs (B, R, 7))`, and the PettingZoo
    dict form `act`), so the protocols that score evolved teams score it too.  Greedy (argmax) by default;
    the GRU's hidden state is carried from tick to tick and cleared by `reset`."""

    def __init__(self, actor: nn.Module, method: str, frame_stack: int = 1, n_robots: int = 3,
                 deterministic: bool = True, seed: int = 0, agents: Sequence[str] | None = None) -> None:
        self.actor = actor
        self.method = method
        self.recurrent = method != "ppo_ff"
        self.k = frame_stack
        self.n_robots = n_robots
        self.deterministic = deterministic
        self.rng = np.random.default_rng(seed)
        self.agents = list(agents) if agents is not None else [f"robot_{k}" for k in range(n_robots)]
        self._n = 0
        self._h: torch.Tensor | None = None
        self._stack: FrameStack | None = None

    def reset(self, n_episodes: int = 1) -> None:
        self._n = int(n_episodes)
        n = self._n * self.n_robots
        if self.recurrent:
            # any nn.Module with initial_state (GRUNet); torch types module attributes as Tensor | Module
            self._h = self.actor.initial_state(n)  # type: ignore[operator]
        else:
            self._stack = FrameStack(n, actor_inputs(self.n_robots), self.k)

    def act_batch(self, obs: np.ndarray) -> np.ndarray:
        B, R, _ = obs.shape
        if B != self._n or (self._h is None and self._stack is None):
            self.reset(B)
        x = slot_observations(np.asarray(obs, dtype=np.float32))
        with torch.no_grad():
            if self.recurrent:
                logits, self._h = self.actor(torch.from_numpy(x)[None], self._h)
                logits = logits[0]
            else:
                assert self._stack is not None  # reset() made it: a feed-forward policy has no hidden state
                logits = self.actor(torch.from_numpy(self._stack.push(x)))
        if self.deterministic:
            a = logits.argmax(dim=1).numpy()
        else:
            a = sample_actions(torch.softmax(logits, dim=1).numpy(), self.rng)
        return a.astype(np.int64).reshape(B, R)


def sample_actions(probs: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One categorical draw per row of `probs` (N, A) from a numpy generator (its state is checkpointed)."""
    n_rows: int = probs.shape[0]  # typed, so numpy's stubs pick the array overload of random()
    u = rng.random(n_rows)
    a = (u[:, None] > np.cumsum(probs, axis=1)).sum(axis=1)
    return np.minimum(a, probs.shape[1] - 1)
