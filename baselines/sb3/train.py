"""Train one RL baseline run: config -> SB3 model on `PatrolReturnVecEnv`, with budget-indexed evaluations.

A run directory holds `config.json` (everything needed to reproduce and evaluate it), `eval_log.csv` (the
greedy policy's team fitness and `solved` on every map at regular budgets: the RL side of the comparison
curves), `model.zip` (final), `best_model.zip` (best training-map fitness so far: the analogue of evolution's
champion, selected on the training map only), `summary.json` and TensorBoard logs under `tb/`.
Budgets are robot-steps (SB3's `num_timesteps`: one slot = one robot for one tick), the unit in which
evolution's budget (teams evaluated x ticks x robots) is also counted.
"""
from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mahn_envs.core.params import TaskParams
from mahn_envs.maps import load_map

from ..io import write_csv, write_json
from ..vec_env import PatrolReturnVecEnv, register_with_sb3
from .algos import get_algo, resolved_hyperparams

EVAL_MAPS = ("plus", "asymmetric_plus")


@dataclass
class TrainConfig:
    """One run.  `max_cycles` / `signal_tick` shorten episodes for tests; comparisons use the defaults."""

    algo: str
    steps: int
    seed: int = 0
    map: str = "plus"
    n_episodes: int = 16
    max_cycles: int = 1364
    signal_tick: int = 690
    reward_scale: float = 0.1
    eval_every: int = 0  #: robot-steps between evaluations; 0 = steps / 20
    eval_maps: Sequence[str] = EVAL_MAPS
    torch_threads: int = 1
    tensorboard: bool = True
    hyperparams: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        get_algo(self.algo)
        if self.steps < 1:
            raise ValueError(f"steps must be positive, got {self.steps}")
        self.eval_maps = list(self.eval_maps)

    def check_budget(self) -> None:
        """A run must end at least one episode in every slot, or its "best" model is the untrained policy.
        (Checked when training starts, not on loading, so older short runs stay readable.)"""
        slots = self.n_episodes * load_map(self.map).n_robots
        if self.steps < self.max_cycles * slots:
            raise ValueError(f"steps ({self.steps}) must cover at least one full episode per slot: max_cycles x "
                             f"n_episodes x robots = {self.max_cycles} x {self.n_episodes} x {slots // self.n_episodes}"
                             f" = {self.max_cycles * slots} robot-steps")

    @property
    def task_params(self) -> TaskParams:
        return TaskParams(max_cycles=self.max_cycles, signal_tick=self.signal_tick)

    @property
    def eval_interval(self) -> int:
        return self.eval_every if self.eval_every > 0 else max(1, self.steps // 20)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["hyperparams"] = resolved_hyperparams(self.algo, self.hyperparams)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TrainConfig:
        return cls(**d)


EVAL_FIELDS_FIXED = ("steps", "episodes_trained", "wall_time")


def eval_fields(maps: Sequence[str]) -> list[str]:
    out = list(EVAL_FIELDS_FIXED)
    for m in maps:
        out += [f"fitness_{m}", f"solved_{m}"]
    return out


def _make_callback(cfg: TrainConfig, out: Path, n_robots: int):
    """Callback (built lazily: SB3) that evaluates at budget points, keeps the best model, logs solved rates."""
    from stable_baselines3.common.callbacks import BaseCallback

    from ..protocols import run_protocol
    from .policy import SB3TeamPolicy

    class BudgetEval(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.rows: list[dict[str, Any]] = []
            self.next_eval = 0
            self.best = -float("inf")
            self.t0 = time.perf_counter()
            self.episodes = 0
            self.solved_recent: list[bool] = []

        def evaluate(self) -> None:
            policy = SB3TeamPolicy(self.model, deterministic=True)
            row: dict[str, Any] = {"steps": self.num_timesteps, "episodes_trained": self.episodes,
                                   "wall_time": round(time.perf_counter() - self.t0, 3)}
            for m in cfg.eval_maps:
                s = run_protocol("training", policy, m, cfg.task_params, episodes=1, seed=cfg.seed).summary()
                row[f"fitness_{m}"] = round(s["fitness"], 6)
                row[f"solved_{m}"] = int(s["solved"])
                self.logger.record(f"eval/fitness_{m}", s["fitness"])
                self.logger.record(f"eval/solved_{m}", int(s["solved"]))
            self.rows.append(row)
            write_csv(out / "eval_log.csv", eval_fields(cfg.eval_maps), self.rows)
            train_fit = row[f"fitness_{cfg.map}"] if cfg.map in cfg.eval_maps else 0.0
            if train_fit > self.best:
                self.best = train_fit
                self.model.save(out / "best_model.zip")
            self.next_eval = self.num_timesteps + cfg.eval_interval

        def _on_training_start(self) -> None:
            self.t0 = time.perf_counter()
            self.evaluate()

        def _on_step(self) -> bool:
            dones = self.locals.get("dones")
            if dones is not None and dones.any():
                infos = self.locals.get("infos", [])
                ended = [i.get("solved", False) for i in infos[::n_robots] if "team_fitness" in i]
                self.episodes += len(ended)
                self.solved_recent = (self.solved_recent + ended)[-100:]
                if self.solved_recent:
                    self.logger.record("rollout/solved_rate", sum(self.solved_recent) / len(self.solved_recent))
            if self.num_timesteps >= self.next_eval:
                self.evaluate()
            return True

        def _on_training_end(self) -> None:
            if not self.rows or self.rows[-1]["steps"] != self.num_timesteps:
                self.evaluate()

    return BudgetEval()


def make_env(cfg: TrainConfig) -> PatrolReturnVecEnv:
    return PatrolReturnVecEnv(cfg.n_episodes, map=cfg.map, params=cfg.task_params, reward_scale=cfg.reward_scale)


def train(cfg: TrainConfig, out: str | Path, progress: bool = False) -> dict[str, Any]:
    """Train, evaluate along the way, save models and write the run's files; returns the summary."""
    import torch

    cfg.check_budget()
    register_with_sb3()
    torch.set_num_threads(max(1, cfg.torch_threads))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "config.json", cfg.to_dict())
    spec = get_algo(cfg.algo)
    env = make_env(cfg)
    # PatrolReturnVecEnv implements SB3's VecEnv interface without subclassing it (vec_env stays torch-free)
    model = spec.model_class()(spec.policy, env, seed=cfg.seed, device="cpu", verbose=0,  # type: ignore[arg-type]
                               tensorboard_log=str(out / "tb") if cfg.tensorboard else None,
                               **resolved_hyperparams(cfg.algo, cfg.hyperparams))
    callback = _make_callback(cfg, out, env.n_robots)
    t0 = time.perf_counter()
    model.learn(total_timesteps=cfg.steps, callback=callback, tb_log_name=cfg.algo, progress_bar=progress)
    wall = time.perf_counter() - t0
    model.save(out / "model.zip")
    rows = callback.rows
    best_row = max(rows, key=lambda r: r[f"fitness_{cfg.map}"]) if cfg.map in cfg.eval_maps else rows[-1]
    summary = {"algo": cfg.algo, "seed": cfg.seed, "steps": int(model.num_timesteps), "wall_time": round(wall, 2),
               "robot_steps_per_second": round(model.num_timesteps / wall, 1), "episodes_trained": callback.episodes,
               "final": {k: v for k, v in rows[-1].items() if k.startswith(("fitness_", "solved_"))},
               "best": {k: v for k, v in best_row.items() if k.startswith(("fitness_", "solved_"))},
               "best_at_steps": best_row["steps"],
               "first_solved_steps": next((r["steps"] for r in rows if r.get(f"solved_{cfg.map}")), None)}
    write_json(out / "summary.json", summary)
    env.close()
    return summary


def load_config(run_dir: str | Path) -> TrainConfig:
    from ..io import read_json

    d = read_json(Path(run_dir) / "config.json")
    algo = d["algo"]
    defaults = resolved_hyperparams(algo)
    d["hyperparams"] = {k: v for k, v in d.get("hyperparams", {}).items() if defaults.get(k) != v}
    return TrainConfig.from_dict(d)


def run_exists(run_dir: str | Path) -> bool:
    return (Path(run_dir) / "summary.json").exists()


def default_out(algo: str, seed: int, root: str | Path = "runs/baselines") -> Path:
    return Path(root) / f"{algo}_seed{seed}"
