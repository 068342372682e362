"""Most general solutions and their transfer tests.

The paper picks, in each run, the solution that generalises best (25 noisy evaluations on the training map),
takes the best of those from distinct runs, and moves them to the real robots on the plus and asymmetric plus
maps with the sequential call-home protocol.  Here the same teams go through both protocols on both maps, in
simulation, exactly and under the generalisation noise.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core import BatchSim

from ..evaluation.eval_champion import champion_policy, evaluate_champion
from ..evaluation.final_population import KIND as FINAL_KIND
from ..evaluation.final_population import validate_final_population
from ..evaluation.generalize import generalize
from ..evaluation.margins import decision_margins
from ..evaluation.protocols import sequential, sequential_episode
from ..evaluation.task_setup import task_params
from ..storage.files import read_versioned_json
from ..training.champion import Champion
from .plan import ExperimentPlan
from .table import RunRecord

TRANSFER_MAPS = ("plus", "asymmetric_plus")
# The robustness test of a transferred team (issue 15's target): this share of its noisy sequential episodes must
# succeed on every transfer map.  The paper's own test is one real episode per map (`transfers`).
ROBUST_SUCCESS = 0.8


def robust_on_every_map(transfer: dict[str, Any]) -> bool:
    """Whether a team's transfer tests (`transfer_tests`) pass the noisy sequential protocol on every transfer map
    in at least ROBUST_SUCCESS of the episodes: the test a team must pass to be trusted on real robots, since one
    noise-free episode per map (the paper's count) says nothing about a decision that noise flips."""
    return all(transfer[m]["sequential_noisy"]["success_fraction"] >= ROBUST_SUCCESS - 1e-9 for m in TRANSFER_MAPS)


def validate_final_populations(plan: ExperimentPlan, runs: list[RunRecord], log: Callable[[str], None] = print
                               ) -> None:
    """With plan.final_validation: `validate_final_population` for every finished run that has not been validated
    with that many episodes yet (its final_validation.json says), so its archive holds its final population's
    best noise-free solution before the generalisation test ranks the archive."""
    if not plan.final_validation:
        return
    done = 0
    for r in runs:
        record = r.folder / "final_validation.json"
        if not r.finished or not (r.folder / "checkpoint.json").exists():
            continue
        if record.exists():
            saved = read_versioned_json(record, FINAL_KIND)
            stage = saved.get("sequential", {})
            if (saved.get("episodes"), saved.get("generation"), stage.get("teams", 0),
                    stage.get("family", {}).get("episodes", 0), stage.get("engine", "pymunk")) == \
                    (plan.final_validation, r.generations, plan.final_sequential, plan.final_family,
                     plan.final_engine if plan.final_sequential else "pymunk"):
                continue  # validated so since the run last changed (a longer run validates again)
        validate_final_population(r.folder, episodes=plan.final_validation, sequential_teams=plan.final_sequential,
                                  family_episodes=plan.final_family, engine=plan.final_engine)
        done += 1
    if done:
        seq = f", the best {plan.final_sequential} in the sequential protocol" if plan.final_sequential else ""
        seq += f" on the map and {plan.final_family} of its plus variants" if plan.final_family else ""
        seq += f" ({plan.final_engine})" if plan.final_sequential else ""
        log(f"final validation ({plan.final_validation} episodes{seq}) of {done} run(s)")


def most_general(plan: ExperimentPlan, runs: list[RunRecord], mode: str,
                 log: Callable[[str], None] = print) -> list[dict[str, Any]]:
    """The `plan.top` most general teams of a mode, one per run: solutions first (a run that found none
    offers its champion, marked as such, so an unsuccessful mode can still be inspected)."""
    entries = []
    for r in runs:
        if r.mode != mode or not r.finished:
            continue
        rows = generalize(r.folder, episodes=plan.general_episodes, map=plan.map, seed=plan.seed)
        top = rows[0]
        chosen = final_pick(r.folder) if plan.general_from == "final_validation" else None
        if chosen is not None:
            top = next((row for row in rows if row["file"] == Path(chosen["file"]).name), top)
        archived = r.folder / "archive" / top["file"]
        path = archived if archived.exists() else r.folder / top["file"]
        entry = {"run": r.name, "seed": r.seed, "file": str(path.relative_to(r.folder.parent.parent)),
                 "solution": archived.exists(), "generation": top["generation"],
                 "training_fitness": top["training_fitness"], "candidates": len(rows),
                 "general_solved_fraction": top["solved_fraction"],
                 "general_mean_fitness": top["mean_fitness"], "general_std_fitness": top["std_fitness"]}
        if plan.general_rank == "protocol":
            entry["validation_protocol_successes"] = _protocol_successes(chosen, top["file"])
        entries.append(entry)
    entries.sort(key=lambda e: (not e["solution"], -e.get("validation_protocol_successes", 0),
                                -e["general_solved_fraction"], -e["general_mean_fitness"], e["run"]))
    by = ("the final validation's sequential successes, then generalisation" if plan.general_rank == "protocol"
          else "generalisation")
    log(f"{mode}: {len(entries)} run(s) ranked by {by}, {sum(e['solution'] for e in entries)} with "
        f"solutions; transferring the top {min(plan.top, len(entries))}")
    return entries[:plan.top]


def final_pick(run: Path) -> dict[str, Any] | None:
    """The run's final-validation pick as its final_validation.json records it (its archive file, reading and
    validation scores; None: not validated, or no pick)."""
    record = run / "final_validation.json"
    if not record.exists():
        return None
    chosen: dict[str, Any] | None = read_versioned_json(record, FINAL_KIND).get("chosen")
    return chosen


def _protocol_successes(chosen: dict[str, Any] | None, file: str) -> int:
    """The pick's noisy sequential successes in its final validation, on the map and on the run's plus variants
    (0 for a run whose team is not the pick: it has no such score)."""
    if chosen is None or Path(chosen["file"]).name != file:
        return 0
    return int(chosen.get("sequential_successes", 0)) + int(chosen.get("family_successes", 0))


def transfer_tests(champ: Champion, plan: ExperimentPlan) -> dict[str, Any]:
    """Both protocols on both maps, exact (1 episode) and noisy (plan.transfer_episodes episodes), and the
    team's decision margins on the training map (a team that decides by ties will not survive noise).  The noisy
    episodes use plan.transfer_noise."""
    noisy = champ.task(task_params(plan.transfer_noise))
    exact_task = champ.task()
    out: dict[str, Any] = {}
    for m in TRANSFER_MAPS:
        exact = evaluate_champion(champ, map=m, episodes=1, seed=plan.seed)
        noise = evaluate_champion(champ, map=m, episodes=plan.transfer_episodes, params=noisy, seed=plan.seed)
        seq = sequential(champion_policy(champ), map=m, params=exact_task, episodes=1, seed=plan.seed)
        seq_noise = sequential(champion_policy(champ), map=m, params=noisy, episodes=plan.transfer_episodes,
                               seed=plan.seed)
        out[m] = {
            "training": {"fitness": exact["fitness"], "solved": exact["solved"]},
            "training_noisy": {"fitness": noise["fitness"], "solved_fraction": noise["solved_fraction"]},
            "sequential": {"success": bool(seq["solved"][0]), "stages": float(seq["fitness"][0])},
            "sequential_noisy": {"success_fraction": float(np.mean(seq_noise["solved"])),
                                 "stages": float(np.mean(seq_noise["fitness"]))},
        }
    out["transfers"] = all(out[m]["sequential"]["success"] for m in TRANSFER_MAPS)
    out["margins"] = decision_margins(champ, map=plan.map, seed=plan.seed)
    return out


def replays(champ: Champion, folder: Path, stem: str, seed: int = 0) -> list[Path]:
    """GIFs of the team in each protocol on each transfer map (exact, no noise)."""
    from ..plots import save_gif

    written = []
    for m in TRANSFER_MAPS:
        path = folder / f"{stem}_{m}_training.gif"
        evaluate_champion(champ, map=m, seed=seed, video=path, video_every=6, video_scale=0.6)
        written.append(path)
        frames: list = []
        sequential_episode(champion_policy(champ), map=m, params=champ.task(), seed=seed, frames=frames, frame_every=12)
        path = folder / f"{stem}_{m}_sequential.gif"
        save_gif(frames, path, fps=15, scale=0.6)
        written.append(path)
    return written


def trajectories(champ: Champion, seed: int = 0) -> dict[str, tuple[np.ndarray, int | None]]:
    """Paths for the figure: (T, R, >=2) per map and protocol, with the signal tick where there is one."""
    paths: dict[str, tuple[np.ndarray, int | None]] = {}
    for m in TRANSFER_MAPS:
        sim = BatchSim(m, 1, champ.task())  # driven with the team's own settings, as everywhere
        res = sim.run_controllers(champ.controllers, record=True)
        assert res.trajectories is not None  # record=True records them
        paths[f"{m} / training"] = (res.trajectories[0], sim.params.signal_tick)
        seq = sequential_episode(champion_policy(champ), map=m, params=champ.task(), seed=seed, record=True)
        assert seq.trajectory is not None  # record=True records it
        paths[f"{m} / sequential"] = (seq.trajectory, None)
    return paths
