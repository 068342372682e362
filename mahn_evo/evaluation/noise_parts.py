"""Which part of the noise breaks a team: the same episodes under the whole noise, none, and each level alone.

A team that fails under the generalisation noise can fail for different reasons, and they call for different
remedies. Measured on hardened populations (docs/results/selection/): teams that pass the sequential protocol on
plus noise-free in 20 of 20 episodes fail it in every episode under the sensor noise alone (their robots do not
come home when called), while other teams fail the one-sided variants with no noise at all (their patrol misses
the offset arms). `mahn-evo eval --noise-parts` plays a team's episodes once per part and says which.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from mahn_envs.core.params import NOISE_FIELDS, TaskParams

from ..training.champion import Champion
from .eval_champion import champion_policy, evaluate_champion
from .protocols import sequential


def noise_part_params(params: TaskParams) -> dict[str, TaskParams]:
    """name -> task: "all" (params), "none" (no noise) and "<level> only" for each noise level of params above 0.

    Raises ValueError when params has no noise (there would be nothing to take apart)."""
    levels = [name for name in NOISE_FIELDS if getattr(params, name) > 0]
    if not levels:
        raise ValueError("noise parts need a task with noise: use --noise generalization or set a noise level "
                         f"({', '.join('--' + n.replace('_', '-') for n in NOISE_FIELDS)})")
    parts = {"all": params, "none": params.without_noise()}
    for name in levels:
        parts[f"{name} only"] = params.only_noise(name)
    return parts


def noise_parts(champion: Champion | str | Path, params: TaskParams, map: str = "plus", protocol: str = "training",
                engine: str = "kinematic", episodes: int = 10, seed: int = 0) -> list[dict[str, Any]]:
    """One row per part of the noise (`noise_part_params`): the same `episodes` episodes (same seed) of `protocol`
    under that part.  Training protocol: mean team fitness and solved fraction (`evaluate_champion`); sequential
    protocol (pymunk, as the transfer test): success fraction and mean fraction of stages done."""
    if protocol not in ("training", "sequential"):
        raise ValueError(f"protocol must be 'training' or 'sequential', got {protocol!r}")
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"episodes must be a positive integer, got {episodes!r}")
    champ = champion if isinstance(champion, Champion) else Champion.load(champion)
    policy = champion_policy(champ) if protocol == "sequential" else None
    rows = []
    for name, part in noise_part_params(params).items():
        row: dict[str, Any] = {"noise": name, "params": {n: getattr(part, n) for n in NOISE_FIELDS}}
        if policy is not None:
            result = sequential(policy, map=map, params=champ.task(part), episodes=episodes, seed=seed)
            row["success_fraction"] = sum(result["solved"]) / episodes
            row["stages"] = sum(result["fitness"]) / episodes
        else:
            result = evaluate_champion(champ, map=map, engine=engine, episodes=episodes, params=part, seed=seed)
            row["fitness"] = result["fitness"]
            row["solved_fraction"] = result["solved_fraction"]
        rows.append(row)
    return rows


def noise_parts_summary(rows: list[dict[str, Any]], protocol: str, episodes: int, map: str) -> str:
    """The rows as a small table, one line per part of the noise."""
    lines = [f"{protocol} protocol on {map}, {episodes} episode(s) per part of the noise:"]
    for row in rows:
        if protocol == "sequential":
            what = f"success {100 * row['success_fraction']:5.1f}%  stages {100 * row['stages']:5.1f}%"
        else:
            what = f"fitness {row['fitness']:8.3f}  solved {100 * row['solved_fraction']:5.1f}%"
        lines.append(f"  {row['noise']:<26} {what}")
    return "\n".join(lines)
