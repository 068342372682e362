"""Score a trained run (SB3 or `mahn-baselines lean`) with the metric of `mahn-evo eval` (team fitness, solved)
on maps x protocols.

The task parameters (episode length, signal tick) come from the run's `config.json`, so a model is scored on the
task it was trained for.  With the default noise-free task and a greedy policy every episode is identical, so
one episode is exact; `episodes` > 1 matters for `stochastic=True` (sampled actions) or noisy protocols.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .io import write_json
from .protocols import TeamPolicy, run_protocol
from .sb3.algos import get_algo, load_model
from .sb3.policy import SB3TeamPolicy
from .sb3.train import EVAL_MAPS, load_config


def model_path(run_dir: str | Path, which: str = "best") -> Path:
    """`best` (best training-map fitness seen during training; falls back to final) or `final`."""
    run_dir = Path(run_dir)
    if which not in ("best", "final"):
        raise ValueError(f"which must be 'best' or 'final' for an SB3 run (best_sampled: lean runs), got {which!r}")
    best = run_dir / "best_model.zip"
    path = best if which == "best" and best.exists() else run_dir / "model.zip"
    if not path.exists():
        raise FileNotFoundError(f"no trained model in {run_dir} (expected model.zip); train it first")
    return path


def evaluate_run(run_dir: str | Path, maps: Sequence[str] = EVAL_MAPS,
                 protocols: Sequence[str] = ("training",), episodes: int = 1, seed: int = 0,
                 which: str = "best", stochastic: bool = False, write: bool = True) -> dict[str, Any]:
    """Evaluate a run directory; returns (and writes `eval.json`) {protocol: {map: summary}}.

    A protocol that is not available (e.g. `sequential` before `mahn_evo.evaluation.protocols` exists) is reported as
    `{"error": message}` for that protocol instead of aborting the other evaluations.
    """
    import torch

    from .io import read_json

    if read_json(Path(run_dir) / "config.json").get("kind") == "lean_config":  # a `mahn-baselines lean` run
        from .lean.gru_kernel import limit_blas_threads
        from .lean.nets import LeanTeamPolicy
        from .lean.ppo import load_actor

        lean_cfg, actor = load_actor(run_dir, which)
        torch.set_num_threads(max(1, lean_cfg.torch_threads))
        limit_blas_threads(lean_cfg.torch_threads)
        policy: TeamPolicy = LeanTeamPolicy(actor, lean_cfg.method, lean_cfg.frame_stack,
                                            deterministic=not stochastic, seed=seed)
        task_params = lean_cfg.task_params
        results: dict[str, Any] = {"run": str(run_dir), "algo": lean_cfg.method, "seed": lean_cfg.seed,
                                   "model": {"best": "best_actor.npz", "best_sampled": "best_sampled_actor.npz"}
                                   .get(which, "last checkpoint"),
                                   "deterministic": not stochastic, "episodes": episodes, "eval_seed": seed,
                                   "recurrent": lean_cfg.recurrent, "protocols": {}}
    else:
        cfg = load_config(run_dir)
        torch.set_num_threads(max(1, cfg.torch_threads))
        path = model_path(run_dir, which)
        model = load_model(cfg.algo, str(path))
        policy = SB3TeamPolicy(model, deterministic=not stochastic)
        task_params = cfg.task_params
        results = {"run": str(run_dir), "algo": cfg.algo, "seed": cfg.seed, "model": path.name,
                   "deterministic": not stochastic, "episodes": episodes, "eval_seed": seed,
                   "recurrent": get_algo(cfg.algo).recurrent, "protocols": {}}
    for proto in protocols:
        per_map: dict[str, Any] = {}
        for m in maps:
            try:
                per_map[m] = run_protocol(proto, policy, m, task_params, episodes=episodes, seed=seed).summary()
            except NotImplementedError as exc:
                per_map = {"error": str(exc)}
                break
        results["protocols"][proto] = per_map
    if write:
        write_json(Path(run_dir) / "eval.json", results)
    return results


def format_results(results: dict[str, Any]) -> str:
    lines = [f"{results['run']}  ({results['algo']}, seed {results['seed']}, {results['model']})",
             f"{'protocol':<12}{'map':<18}{'fitness':>10}{'solved':>8}{'rate':>7}"]
    for proto, per_map in results["protocols"].items():
        if "error" in per_map:
            lines.append(f"{proto:<12}unavailable: {per_map['error']}")
            continue
        for m, s in per_map.items():
            lines.append(f"{proto:<12}{m:<18}{s['fitness']:>10.3f}{str(s['solved']):>8}{s['solved_rate']:>7.2f}")
    return "\n".join(lines)
