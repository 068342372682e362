"""A lean PPO loop on torch for IPPO-GRU, MAPPO-GRU and feed-forward PPO (settings and their reasons:
`baselines/lean/config.py`).

Why not SB3 / sb3-contrib here?  Their rollouts are windows shorter than an episode, their recurrent PPO is
slow on this CPU (1-3.6 k robot-steps/s measured) and they have no centralised critic; this loop plays whole
episodes in one vector env (`PatrolReturnVecEnv`, the batch core) and trains on them directly.

One update = one rollout of `n_episodes` whole episodes (slots = episodes x robots), then `epochs` passes of
`minibatches` minibatches.  Recurrent methods cut every slot's episode into chunks of `bptt` ticks; the
hidden state at each chunk's start is the one the rollout produced (stored), and the chunk is replayed from
it with backpropagation through all its ticks.

Run folder (resumable: `train(..., resume=True)` continues bit-identically):
  config.json            the settings (`algo` = the method, as `baselines.comparison.compare` reads it)
  checkpoint.json        versioned: update count, steps, numpy generator state, logs, best; names its weights
  checkpoint_uNNNNNN.npz the state dicts of actor, critic and optimiser as plain arrays (weights_npz.py: no pickle;
                         runs written before it have checkpoint_uNNNNNN.pt, still read, tensors only)
  best_actor.npz         the actor with the best greedy training-map fitness so far (+ best.json)
  best_sampled_actor.npz the actor whose sampled rollout had the best mean team fitness so far (+ best_sampled.json):
                         the sampling policy PPO trains, for `mahn-baselines eval --model best_sampled --stochastic`
  eval_log.csv           greedy team fitness / solved on every eval map (the comparison's greedy curves)
  train_log.csv          per update: training-episode fitness (the sampling policy's: the comparison's
                         `<method>_sampled` curves), losses, entropy, KL, robot-steps/s
  summary.json           at the end
"""
from __future__ import annotations

import math
import pickle  # only for its exception type: legacy torch weights are loaded with weights_only=True
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from mahn_evo.storage.files import atomic_write_json, read_versioned_json, versioned
from mahn_evo.storage.folder_lock import folder_lock

from ..io import new_run_folder, write_csv
from ..protocols import run_protocol
from ..vec_env import PatrolReturnVecEnv
from .allocator import keep_freed_memory
from .config import STOPPING_RULES, LeanConfig
from .gru_kernel import limit_blas_threads
from .nets import GRUNet, LeanTeamPolicy, build_networks, sample_actions, stack_frames
from .weights_npz import load_weights, save_weights

#: episodes per map on which `LeanPPO.evaluate_best_sampled` scores the best sampling policy at the end of a run
SAMPLED_EVAL_EPISODES = 20

TRAIN_FIELDS = ("update", "steps", "wall_time", "cpu_seconds", "fitness_mean", "fitness_max", "solved_rate",
                "policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction", "robot_steps_per_second")


class Rollout:
    """Whole episodes of every slot: arrays (T, N, ...) and, for recurrent methods, the hidden states at the
    starts of the BPTT chunks (n_chunks, N, H)."""

    def __init__(self, T: int, N: int, B: int, n_obs: int, gsize: int, cfg: LeanConfig, hidden: int) -> None:
        self.obs = np.zeros((T, N, n_obs), dtype=np.float32)
        self.actions = np.zeros((T, N), dtype=np.int64)
        self.logp = np.zeros((T, N), dtype=np.float32)
        self.rewards = np.zeros((T, N), dtype=np.float32)
        self.team_rewards = np.zeros((T, B), dtype=np.float32)
        team = cfg.method == "mappo_gru"
        self.values = np.zeros((T, B if team else N), dtype=np.float32)
        self.gstate = np.zeros((T, B, gsize), dtype=np.float32) if team else None
        n_chunks = math.ceil(T / cfg.bptt)
        self.h_actor = np.zeros((n_chunks, N, hidden), dtype=np.float32)
        self.h_critic = np.zeros((n_chunks, N, hidden), dtype=np.float32)
        self.fitness = np.zeros(B)
        self.solved = np.zeros(B, dtype=bool)


def gae(rewards: np.ndarray, values: np.ndarray, gamma: float, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """Advantages and returns of whole episodes that *terminate* after the last row (no bootstrap)."""
    T = rewards.shape[0]
    adv = np.zeros_like(values)
    last = np.zeros(values.shape[1:], dtype=np.float32)
    for t in range(T - 1, -1, -1):
        next_v = values[t + 1] if t + 1 < T else 0.0
        delta = rewards[t] + gamma * next_v - values[t]
        last = delta + gamma * lam * last
        adv[t] = last
    return adv, adv + values


class ValueNorm:
    """Running mean / std of the value targets; critics predict normalised values (MAPPO's value
    normalisation).  Why: the team fitness grows from ~1 to ~170 over training, and untrained critics' outputs
    of +-0.2 would otherwise swamp the advantages of the early, tiny returns (measured: without it PPO's
    fitness fell from 1.15 to 0.74 in 1.4 M robot-steps).  Exponential averages over updates (beta), debiased.
    """

    def __init__(self, beta: float = 0.99) -> None:
        self.beta = beta
        self.acc_mean = 0.0
        self.acc_sq = 0.0
        self.debias = 0.0

    @property
    def mean(self) -> float:
        return self.acc_mean / self.debias if self.debias > 0 else 0.0

    @property
    def std(self) -> float:
        if self.debias <= 0:
            return 1.0
        return math.sqrt(max(self.acc_sq / self.debias - self.mean ** 2, 1e-4))

    def update(self, targets: np.ndarray) -> None:
        t = np.asarray(targets, dtype=np.float64)
        self.acc_mean = self.beta * self.acc_mean + (1 - self.beta) * float(t.mean())
        self.acc_sq = self.beta * self.acc_sq + (1 - self.beta) * float((t ** 2).mean())
        self.debias = self.beta * self.debias + (1 - self.beta)

    def state(self) -> dict[str, float]:
        return {"beta": self.beta, "acc_mean": self.acc_mean, "acc_sq": self.acc_sq, "debias": self.debias}

    def load(self, state: dict[str, float]) -> None:
        self.beta, self.acc_mean = float(state["beta"]), float(state["acc_mean"])
        self.acc_sq, self.debias = float(state["acc_sq"]), float(state["debias"])


class LeanPPO:
    """One run in a folder; `LeanPPO(cfg, out, resume=True)` continues the checkpoint there."""

    def __init__(self, cfg: LeanConfig, out: str | Path, resume: bool = False) -> None:
        torch.set_num_threads(cfg.torch_threads)
        limit_blas_threads(cfg.torch_threads)  # the compiled GRU's per-tick products (gru_kernel)
        keep_freed_memory()  # every minibatch reuses the last one's large buffers (allocator)
        self.cfg = cfg
        self.out = Path(out)
        self.env = PatrolReturnVecEnv(cfg.n_episodes, map=cfg.map, params=cfg.task_params,
                                      reward_scale=cfg.reward_scale, validate_actions=False)
        self.R = self.env.n_robots
        self.N = self.env.num_envs
        self.T = cfg.max_cycles
        self.steps_per_update = self.N * self.T
        torch.manual_seed(cfg.seed)
        self.actor, self.critic = build_networks(cfg, self.R, self.env.global_state_size)
        self.optim = torch.optim.Adam(list(self.actor.parameters()) + list(self.critic.parameters()),
                                      lr=cfg.lr, eps=1e-5)
        self.rng = np.random.default_rng(cfg.seed)
        self.value_norm = ValueNorm()
        self.update = 0
        self.wall = 0.0
        self.cpu = 0.0  #: CPU-seconds of this process (all threads): the compute-matched budget axis
        self.best = -math.inf
        self.best_sampled = -math.inf  #: the best mean team fitness of a rollout (the sampling policy's)
        self.eval_rows: list[dict[str, Any]] = []
        self.train_rows: list[dict[str, Any]] = []
        self.weights_file: str | None = None
        ckpt = self.out / "checkpoint.json"
        if resume:
            self._resume(ckpt)
        else:
            new_run_folder(self.out, "lean_config", cfg.to_dict())
        self.buf = Rollout(self.T, self.N, cfg.n_episodes, self.env.observation_space.shape[0],
                           self.env.global_state_size, cfg, cfg.hidden)

    # ------------------------------------------------------------------ files
    @property
    def steps(self) -> int:
        return self.update * self.steps_per_update

    def _checkpoint(self) -> None:
        name = f"checkpoint_u{self.update:06d}.npz"
        save_weights(self.out / name, {"actor": self.actor.state_dict(), "critic": self.critic.state_dict()},
                     self.optim.state_dict())
        state = {"config": self.cfg.to_dict(), "update": self.update, "steps": self.steps, "weights": name,
                 "rng": self.rng.bit_generator.state, "value_norm": self.value_norm.state(),
                 "wall_seconds": self.wall,
                 "cpu_seconds": self.cpu, "best": None if not math.isfinite(self.best) else self.best,
                 "best_sampled": None if not math.isfinite(self.best_sampled) else self.best_sampled,
                 "eval_rows": self.eval_rows, "train_rows": self.train_rows}
        atomic_write_json(self.out / "checkpoint.json", versioned("lean_checkpoint", state))
        if self.weights_file is not None and self.weights_file != name:
            (self.out / self.weights_file).unlink(missing_ok=True)
        self.weights_file = name

    def _resume(self, ckpt: Path) -> None:
        data = read_versioned_json(ckpt, "lean_checkpoint")
        saved = LeanConfig.from_dict(data["config"]).to_dict()
        asked = self.cfg.to_dict()
        differing = sorted(k for k in asked if k not in STOPPING_RULES and saved.get(k) != asked[k])
        if differing:
            raise ValueError(f"cannot resume {str(self.out)!r}: settings differ in {differing} (the run was made "
                             f"with {', '.join(f'{k} = {saved.get(k)!r}' for k in differing)}); only "
                             f"{list(STOPPING_RULES)} may change")
        path = self.out / data["weights"]
        try:
            weights = _read_weights(path)
            self.actor.load_state_dict(weights["actor"])
            self.critic.load_state_dict(weights["critic"])
            self.optim.load_state_dict(weights["optim"])
        except (ValueError, RuntimeError, KeyError) as exc:
            raise ValueError(f"checkpoint weights {str(path)!r} are missing or damaged ({exc})") from exc
        try:
            self.weights_file = data["weights"]
            self.rng.bit_generator.state = data["rng"]
            self.value_norm.load(data["value_norm"])
            self.update = int(data["update"])
            self.wall = float(data["wall_seconds"])
            self.cpu = float(data["cpu_seconds"])
            self.best = -math.inf if data["best"] is None else float(data["best"])
            # absent from checkpoints written before it: the best sampled actor is kept from the resume on
            sampled = data.get("best_sampled")
            self.best_sampled = -math.inf if sampled is None else float(sampled)
            self.eval_rows = data["eval_rows"]
            self.train_rows = data["train_rows"]
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"checkpoint file {str(ckpt)!r} is damaged or from another format (missing or bad "
                             f"field: {exc})") from exc
        if any(saved.get(k) != asked[k] for k in STOPPING_RULES):
            atomic_write_json(self.out / "config.json", versioned("lean_config", asked))

    # ------------------------------------------------------------------ rollout
    def rollout(self) -> Rollout:
        """Whole episodes of batch number `update` (deterministic per seed): the policy samples its actions."""
        cfg, buf, T = self.cfg, self.buf, self.T
        obs = self.env.reset_at(cfg.seed, self.update)
        recurrent, mappo = cfg.recurrent, cfg.method == "mappo_gru"
        if recurrent:
            assert isinstance(self.actor, GRUNet)  # build_networks: recurrent methods have a GRU actor
            h_a = self.actor.initial_state(self.N)
            h_c: torch.Tensor | None = None
            if not mappo:
                assert isinstance(self.critic, GRUNet)  # ... and, but for MAPPO's centralised MLP, a GRU critic
                h_c = self.critic.initial_state(self.N)
        else:
            stack = np.zeros((self.N, obs.shape[1] * cfg.frame_stack), dtype=np.float32)
            d = obs.shape[1]
        time_col = np.zeros((self.N, 1), dtype=np.float32)
        v_mean, v_std = self.value_norm.mean, self.value_norm.std
        infos: list = []
        with torch.no_grad():
            for t in range(T):
                buf.obs[t] = obs
                x = torch.from_numpy(obs)
                time_col[:] = t / T
                if recurrent:
                    if t % cfg.bptt == 0:
                        buf.h_actor[t // cfg.bptt] = h_a[0].numpy()
                        if h_c is not None:
                            buf.h_critic[t // cfg.bptt] = h_c[0].numpy()
                    logits, h_a = self.actor(x[None], h_a)
                    logits = logits[0]
                    if mappo:
                        assert buf.gstate is not None  # a MAPPO rollout holds the global states
                        g = self.env.global_state(buf.gstate[t])
                        buf.values[t] = self.critic(torch.from_numpy(g))[:, 0].numpy()
                    else:
                        v, h_c = self.critic(torch.cat([x, torch.from_numpy(time_col)], 1)[None], h_c)
                        buf.values[t] = v[0, :, 0].numpy()
                else:
                    stack[:, d:] = stack[:, :-d].copy()
                    stack[:, :d] = obs
                    xs = torch.from_numpy(stack)
                    logits = self.actor(xs)
                    buf.values[t] = self.critic(torch.cat([xs, torch.from_numpy(time_col)], 1))[:, 0].numpy()
                logp_all = torch.log_softmax(logits, dim=1)
                a = sample_actions(logp_all.exp().numpy(), self.rng)
                buf.actions[t] = a
                buf.logp[t] = logp_all.numpy()[np.arange(self.N), a]
                obs, rew, done, infos = self.env.step(a)
                buf.rewards[t] = rew
                buf.team_rewards[t] = rew[::self.R]
        if not done.all():
            raise RuntimeError("internal: a rollout must end with the episodes")  # fixed horizon
        buf.values[:] = buf.values * v_std + v_mean  # critics predict normalised values
        buf.fitness[:] = [infos[b * self.R]["team_fitness"] for b in range(cfg.n_episodes)]
        buf.solved[:] = [infos[b * self.R]["solved"] for b in range(cfg.n_episodes)]
        return buf

    # ------------------------------------------------------------------ update
    def _sequences(self, a: np.ndarray) -> torch.Tensor:
        """(T, N, ...) -> (L, n_chunks * N, ...): chunk c of slot n is sequence c * N + n (zero-padded)."""
        L = self.cfg.bptt
        n_chunks = math.ceil(self.T / L)
        pad = n_chunks * L - self.T
        if pad:
            a = np.concatenate([a, np.zeros((pad,) + a.shape[1:], dtype=a.dtype)])
        # typed: numpy's stubs give a reshape to a tuple of unknown length the shape tuple[()]
        chunks: np.ndarray = a.reshape((n_chunks, L) + a.shape[1:])
        chunks = np.moveaxis(chunks, 1, 0).reshape((L, n_chunks * chunks.shape[2]) + chunks.shape[3:])
        return torch.from_numpy(np.ascontiguousarray(chunks))

    def learn(self, buf: Rollout) -> dict[str, float]:
        cfg, T, N, B = self.cfg, self.T, self.N, self.cfg.n_episodes
        mappo = cfg.method == "mappo_gru"
        if mappo:
            adv_team, ret_team = gae(buf.team_rewards, buf.values, cfg.gamma, cfg.gae_lambda)
            adv = np.repeat(adv_team, self.R, axis=1)
        else:
            adv, ret = gae(buf.rewards, buf.values, cfg.gamma, cfg.gae_lambda)
        self.value_norm.update(ret_team if mappo else ret)
        v_mean, v_std = self.value_norm.mean, self.value_norm.std
        if mappo:
            ret_team = ((ret_team - v_mean) / v_std).astype(np.float32)
        else:
            ret = ((ret - v_mean) / v_std).astype(np.float32)
        time_col = np.broadcast_to((np.arange(T, dtype=np.float32) / T)[:, None, None], (T, N, 1))
        if cfg.recurrent:
            mask = self._sequences(np.ones((T, N), dtype=np.float32))
            obs = self._sequences(buf.obs)
            acts, old_logp, advs = self._sequences(buf.actions), self._sequences(buf.logp), self._sequences(adv)
            h_a = torch.from_numpy(buf.h_actor.reshape(1, -1, cfg.hidden))
            n_seq = obs.shape[1]
            if mappo:
                assert buf.gstate is not None  # a MAPPO rollout holds the global states
                g = torch.from_numpy(buf.gstate.reshape(T * B, -1))
                g_ret = torch.from_numpy(ret_team.reshape(-1))
            else:
                c_in = self._sequences(np.concatenate([buf.obs, time_col], axis=2))
                c_ret = self._sequences(ret)
                h_c = torch.from_numpy(buf.h_critic.reshape(1, -1, cfg.hidden))
        else:
            stacked = stack_frames(buf.obs, cfg.frame_stack).reshape(T * N, -1)
            obs = torch.from_numpy(stacked)
            c_in = torch.from_numpy(np.concatenate([stacked, time_col.reshape(T * N, 1)], axis=1))
            acts = torch.from_numpy(buf.actions.reshape(-1))
            old_logp = torch.from_numpy(buf.logp.reshape(-1))
            advs = torch.from_numpy(adv.reshape(-1))
            c_ret = torch.from_numpy(ret.reshape(-1))
            n_seq = T * N
        stats = {k: 0.0 for k in ("policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction")}
        n_mb = 0
        params = list(self.actor.parameters()) + list(self.critic.parameters())
        for _ in range(cfg.epochs):
            perm = self.rng.permutation(n_seq)
            g_perm = self.rng.permutation(T * B) if (cfg.recurrent and mappo) else None
            for i in range(cfg.minibatches):
                idx = torch.from_numpy(np.sort(perm[i::cfg.minibatches]))
                if cfg.recurrent:
                    logits, _ = self.actor(obs[:, idx], h_a[:, idx])
                    m = mask[:, idx]
                    a, lp_old, ad = acts[:, idx], old_logp[:, idx], advs[:, idx]
                    if mappo:
                        assert g_perm is not None  # drawn above for recurrent MAPPO
                        gi = torch.from_numpy(g_perm[i::cfg.minibatches])
                        v, v_target, vm = self.critic(g[gi])[:, 0], g_ret[gi], None
                    else:
                        v, _ = self.critic(c_in[:, idx], h_c[:, idx])
                        v, v_target, vm = v[..., 0], c_ret[:, idx], m
                else:
                    logits = self.actor(obs[idx])
                    m = torch.ones(len(idx))
                    a, lp_old, ad = acts[idx], old_logp[idx], advs[idx]
                    v, v_target, vm = self.critic(c_in[idx])[:, 0], c_ret[idx], None
                n_valid = m.sum()
                ad_mean = (ad * m).sum() / n_valid
                ad_std = torch.sqrt((((ad - ad_mean) * m) ** 2).sum() / n_valid) + 1e-8
                ad = (ad - ad_mean) / ad_std
                logp_all = torch.log_softmax(logits, dim=-1)
                lp = logp_all.gather(-1, a.unsqueeze(-1)).squeeze(-1)
                ratio = torch.exp(lp - lp_old)
                pg = -torch.min(ratio * ad, torch.clamp(ratio, 1 - cfg.clip, 1 + cfg.clip) * ad)
                policy_loss = (pg * m).sum() / n_valid
                entropy = (-(logp_all.exp() * logp_all).sum(-1) * m).sum() / n_valid
                verr = (v - v_target) ** 2
                value_loss = 0.5 * ((verr * vm).sum() / vm.sum() if vm is not None else verr.mean())
                loss = policy_loss - cfg.ent_coef * entropy + cfg.vf_coef * value_loss
                self.optim.zero_grad(set_to_none=True)
                loss.backward()
                nn.utils.clip_grad_norm_(params, cfg.max_grad_norm)
                self.optim.step()
                with torch.no_grad():
                    log_ratio = lp - lp_old
                    stats["approx_kl"] += float((((ratio - 1) - log_ratio) * m).sum() / n_valid)
                    stats["clip_fraction"] += float((((ratio - 1).abs() > cfg.clip).float() * m).sum() / n_valid)
                stats["policy_loss"] += float(policy_loss.detach())
                stats["value_loss"] += float(value_loss.detach())
                stats["entropy"] += float(entropy.detach())
                n_mb += 1
        return {k: v / n_mb for k, v in stats.items()}

    # ------------------------------------------------------------------ evaluation and loop
    def policy(self, deterministic: bool = True) -> LeanTeamPolicy:
        return LeanTeamPolicy(self.actor, self.cfg.method, self.cfg.frame_stack, self.R, deterministic,
                              seed=self.cfg.seed)

    def evaluate(self) -> dict[str, Any]:
        """Greedy policy, one episode per eval map (noise-free task: one episode is exact)."""
        row: dict[str, Any] = {"steps": self.steps, "episodes_trained": self.update * self.cfg.n_episodes,
                               "wall_time": round(self.wall, 3), "cpu_seconds": round(self.cpu, 3)}
        policy = self.policy()
        for m in self.cfg.eval_maps:
            s = run_protocol("training", policy, m, self.cfg.task_params, episodes=1, seed=self.cfg.seed).summary()
            row[f"fitness_{m}"] = round(s["fitness"], 6)
            row[f"solved_{m}"] = int(s["solved"])
        self.eval_rows.append(row)
        key = f"fitness_{self.cfg.map}"
        if key in row and row[key] > self.best:
            self.best = float(row[key])
            save_weights(self.out / "best_actor.npz", {"actor": self.actor.state_dict()})
            atomic_write_json(self.out / "best.json", versioned("lean_best", {
                "method": self.cfg.method, "update": self.update, "steps": self.steps, "evaluation": row}))
        return row

    def step(self) -> dict[str, Any]:
        t0, c0 = time.perf_counter(), time.process_time()
        buf = self.rollout()
        self._keep_best_sampled(float(buf.fitness.mean()))
        stats = self.learn(buf)
        self.update += 1
        seconds = time.perf_counter() - t0
        self.wall += seconds
        self.cpu += time.process_time() - c0
        row = {"update": self.update, "steps": self.steps, "wall_time": round(self.wall, 3),
               "cpu_seconds": round(self.cpu, 3),
               "fitness_mean": round(float(buf.fitness.mean()), 6), "fitness_max": round(float(buf.fitness.max()), 6),
               "solved_rate": round(float(buf.solved.mean()), 4), **{k: round(v, 6) for k, v in stats.items()},
               "robot_steps_per_second": round(self.steps_per_update / seconds, 1)}
        self.train_rows.append(row)
        if self.cfg.eval_every == 0 or self.update % self.cfg.eval_every == 0:
            self.evaluate()
        return row

    def _keep_best_sampled(self, fitness: float) -> None:
        """After a rollout, before learning from it: the actor that played it, if its episodes' mean team fitness
        is the best so far.  Why: the sampling policy is the one PPO optimises, and its argmax (best_actor.npz) can
        be far worse; this keeps the sampled policy's best for the tests of evolved teams (stochastic evaluation)."""
        if fitness <= self.best_sampled:
            return
        self.best_sampled = fitness
        save_weights(self.out / "best_sampled_actor.npz", {"actor": self.actor.state_dict()})
        atomic_write_json(self.out / "best_sampled.json", versioned("lean_best_sampled", {
            "method": self.cfg.method, "update": self.update + 1, "steps": self.steps + self.steps_per_update,
            "trained_steps": self.steps, "fitness_mean": round(fitness, 6)}))

    def evaluate_best_sampled(self, episodes: int = SAMPLED_EVAL_EPISODES) -> dict[str, Any] | None:
        """The best sampling policy (best_sampled_actor.npz) on `episodes` fresh episodes of every eval map, its
        actions sampled from a generator of its own (seed + 1: the training's is untouched): mean team fitness,
        its standard deviation and the solved rate per map.  Why: the best update's own score is the largest of
        many noisy means, biased upwards; this estimate is not, and it covers the test map too.  None before a
        best sampling policy exists."""
        path = self.out / "best_sampled_actor.npz"
        if not path.exists():
            return None
        torch_rng = torch.get_rng_state()  # building networks draws initial weights: leave the generator as it was
        actor, _ = build_networks(self.cfg, self.R, self.env.global_state_size)
        torch.set_rng_state(torch_rng)
        actor.load_state_dict(load_weights(path)["actor"])
        out: dict[str, Any] = {"episodes": episodes}
        for m in self.cfg.eval_maps:
            policy = LeanTeamPolicy(actor, self.cfg.method, self.cfg.frame_stack, self.R, deterministic=False,
                                    seed=self.cfg.seed + 1)
            s = run_protocol("training", policy, m, self.cfg.task_params, episodes=episodes,
                             seed=self.cfg.seed).summary()
            out[m] = {"fitness": round(s["fitness"], 6), "fitness_std": round(s["fitness_std"], 6),
                      "solved_rate": round(s["solved_rate"], 4)}
        return out

    def _write_logs(self) -> None:
        maps = self.cfg.eval_maps
        write_csv(self.out / "eval_log.csv", ["steps", "episodes_trained", "wall_time", "cpu_seconds"] +
                  [f"{k}_{m}" for m in maps for k in ("fitness", "solved")], self.eval_rows)
        write_csv(self.out / "train_log.csv", TRAIN_FIELDS, self.train_rows)

    def done(self) -> bool:
        return self.steps >= self.cfg.steps

    def run(self, on_update: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:
        if not self.eval_rows:
            self.evaluate()
        while not self.done():
            row = self.step()
            if self.update % self.cfg.checkpoint_every == 0 or self.done():
                self._write_logs()
                self._checkpoint()
            if on_update is not None:
                on_update(row)
        return self.finish()

    def finish(self) -> dict[str, Any]:
        self._write_logs()
        self._checkpoint()
        m = self.cfg.map
        rows = self.eval_rows
        best_row = max(rows, key=lambda r: r.get(f"fitness_{m}", -math.inf))
        summary = {"algo": self.cfg.method, "seed": self.cfg.seed, "steps": self.steps, "updates": self.update,
                   "wall_time": round(self.wall, 2), "cpu_seconds": round(self.cpu, 2),
                   "robot_steps_per_second": round(self.steps / self.wall, 1) if self.wall > 0 else None,
                   "episodes_trained": self.update * self.cfg.n_episodes,
                   "final": {k: v for k, v in rows[-1].items() if k.startswith(("fitness_", "solved_"))},
                   "best": {k: v for k, v in best_row.items() if k.startswith(("fitness_", "solved_"))},
                   "best_at_steps": best_row["steps"],
                   "first_solved_steps": next((r["steps"] for r in rows if r.get(f"solved_{m}")), None),
                   # the sampling policy PPO trains, as baselines.comparison.compare.sampled_curve reads it: its
                   # best update, and that update's actor scored again on fresh episodes
                   "best_sampled": _best_sampled(self.train_rows),
                   "best_sampled_evaluation": self.evaluate_best_sampled()}
        atomic_write_json(self.out / "summary.json", summary)
        return summary


def _best_sampled(train_rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The update whose training episodes (played by the sampling policy) had the best mean team fitness."""
    if not train_rows:
        return None
    best = max(train_rows, key=lambda r: r["fitness_mean"])
    return {"fitness_mean": best["fitness_mean"], "solved_rate": best["solved_rate"], "steps": best["steps"]}


def load_actor(run_dir: str | Path, which: str = "best") -> tuple[LeanConfig, nn.Module]:
    """The actor of a run (`best`: best_actor.npz, the best greedy policy; `best_sampled`: best_sampled_actor.npz,
    the best sampling policy; `final`: the last checkpoint's)."""
    run_dir = Path(run_dir)
    data = read_versioned_json(run_dir / "config.json", "lean_config")
    cfg = LeanConfig.from_dict(data)
    env = PatrolReturnVecEnv(1, map=cfg.map, params=cfg.task_params)
    actor, _ = build_networks(cfg, env.n_robots, env.global_state_size)
    if which == "best":
        path = run_dir / "best_actor.npz"
        if not path.exists() and (run_dir / "best_actor.pt").exists():
            path = run_dir / "best_actor.pt"  # a run written before the NPZ format
    elif which == "best_sampled":
        path = run_dir / "best_sampled_actor.npz"
        if not path.exists():
            raise FileNotFoundError(f"{str(run_dir)!r} has no best_sampled_actor.npz (runs written before it keep "
                                    "only best_actor.npz and their last checkpoint)")
    elif which == "final":
        path = run_dir / read_versioned_json(run_dir / "checkpoint.json", "lean_checkpoint")["weights"]
    else:
        raise ValueError(f"which must be 'best', 'best_sampled' or 'final', got {which!r}")
    actor.load_state_dict(_read_weights(path)["actor"])
    return cfg, actor


def _read_weights(path: Path) -> dict[str, Any]:
    """`load_weights`, or for a run written before the NPZ format, its torch file (tensors only: weights_only;
    a best-actor file held the actor's state dict alone)."""
    if path.suffix != ".pt":
        return load_weights(path)
    try:
        state = torch.load(path, weights_only=True)
    except (OSError, RuntimeError, EOFError, pickle.UnpicklingError) as exc:
        raise ValueError(f"weights file {str(path)!r} is missing or damaged ({exc})") from exc
    return state if "actor" in state else {"actor": state}


def train(cfg: LeanConfig, out: str | Path, resume: bool = False,
          on_update: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:
    """Run (or, with resume=True and a checkpoint in `out`, continue) a lean PPO run; returns the summary."""
    has_ckpt = (Path(out) / "checkpoint.json").exists()
    with folder_lock(out, "lean PPO run folder"):  # one writer per run (a second would interleave its updates)
        return LeanPPO(cfg, out, resume=resume and has_ckpt).run(on_update)
