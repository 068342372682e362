"""The paper's table from finished run folders: solved runs per mode, generations to the first solution,
Fisher's exact test between two modes, and the per-generation curves behind the figures.

Only finished runs count (a run still in progress is reported as such), so the table can be written while an
experiment is still running and is never biased by runs that simply have not had their generations yet.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..storage.files import read_json_object
from ..training.config import robust_phase_start
from .plan import ExperimentPlan

#: The paper's figures (IROS 2011, 15 runs per mode, population 500, up to 1000 generations).
PAPER: dict[str, Any] = {  # the paper's numbers: per mode a dict, plus the Fisher p and transfer text
    "situational": {"runs": 15, "solved": 15, "generations_mean": 264.6, "generations_sd": 246.28},
    "standard": {"runs": 15, "solved": 3},
    "fisher_p": "< 0.0001",
    "transfer": "5/5 most general situational solutions transfer to both real-world maps",
}


@dataclass
class RunRecord:
    name: str
    mode: str
    seed: int
    folder: Path
    finished: bool
    generations: int  # generations run so far
    solved: bool
    first_solved: int | None  # 0-based generation index of the first solution
    best_fitness: float | None
    wall_seconds: float
    best_ever: np.ndarray  # per generation
    #: with robust_from "first_solution": whether a generation scored under noise held a team that solved all its
    #: episodes (None: the plan has no such phase)
    solved_under_noise: bool | None = None

    @property
    def generations_to_solve(self) -> int | None:
        """Generations evaluated up to and including the first solution (1-based, as the paper counts)."""
        return None if self.first_solved is None else self.first_solved + 1

    def at_generation(self, limit: int) -> RunRecord:
        """This run as if its limit had been `limit` generations (<= the limit it ran with): solved only by a
        solution found within them, and the best fitness reached by then.  A run stopped earlier (at its first
        solution) is unchanged; one still running counts as finished once it has run `limit` generations."""
        if self.generations < limit or (self.generations == limit and self.finished):
            return self
        first = self.first_solved if self.first_solved is not None and self.first_solved < limit else None
        best = float(self.best_ever[limit - 1]) if len(self.best_ever) >= limit else self.best_fitness
        return replace(self, finished=True, generations=limit, solved=first is not None, first_solved=first,
                       best_fitness=best, best_ever=self.best_ever[:limit])

    def to_dict(self) -> dict[str, Any]:
        d = {"run": self.name, "mode": self.mode, "seed": self.seed, "finished": self.finished,
             "generations": self.generations, "solved": self.solved,
             "generations_to_solve": self.generations_to_solve, "best_fitness": self.best_fitness,
             "wall_seconds": round(self.wall_seconds, 1)}
        if self.solved_under_noise is not None:
            d["solved_under_noise"] = self.solved_under_noise
        return d


def _read_log(path: Path) -> list[dict[str, str]]:
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def load_run(plan: ExperimentPlan, mode: str, seed: int, folder: Path) -> RunRecord:
    rows = _read_log(folder / "log.csv")
    best = np.array([float(r["best_ever"]) for r in rows]) if rows else np.zeros(0)
    first = next((int(r["generation"]) for r in rows if int(r["n_solved"]) > 0), None)
    gens = len(rows)
    summary = {}
    if (folder / "summary.json").exists():
        try:
            summary = read_json_object(folder / "summary.json", "summary")
        except ValueError:
            summary = {}  # damaged: the run counts as unfinished, and finishing it rewrites the summary
    finished = bool(summary) and summary.get("generations") == gens and (
        gens >= plan.generations or (first is not None and gens > first + plan.after_solved))
    wall = float(sum(float(r["seconds"]) for r in rows))
    under_noise = None
    if plan.robust_from == "first_solution":
        start = robust_phase_start(plan.robust_from, plan.robust_delay, first)
        under_noise = start is not None and any(int(r["n_solved"]) > 0 for r in rows[start:])
    return RunRecord(folder.name, mode, seed, folder, finished, gens, first is not None, first,
                     float(best.max()) if gens else None, wall, best, under_noise)


def load_runs(plan: ExperimentPlan, out: str | Path) -> list[RunRecord]:
    return [load_run(plan, m, s, f) for m, s, f in plan.tasks(out)]


def mode_table(plan: ExperimentPlan, runs: list[RunRecord]) -> dict[str, dict[str, Any]]:
    table = {}
    for mode in plan.modes:
        done = [r for r in runs if r.mode == mode and r.finished]
        gens = np.array([r.generations_to_solve for r in done if r.solved], dtype=float)
        table[mode] = {
            "runs_finished": len(done),
            "runs_in_progress": sum(1 for r in runs if r.mode == mode and not r.finished),
            "solved": int(len(gens)),
            "solved_rate": float(len(gens) / len(done)) if done else None,
            "generations_mean": float(gens.mean()) if len(gens) else None,
            "generations_sd": float(gens.std(ddof=1)) if len(gens) > 1 else None,
            "generations_median": float(np.median(gens)) if len(gens) else None,
            "generations_min": int(gens.min()) if len(gens) else None,
            "generations_max": int(gens.max()) if len(gens) else None,
            "best_fitness_median": float(np.median([r.best_fitness for r in done])) if done else None,
            "wall_seconds_total": round(sum(r.wall_seconds for r in runs if r.mode == mode), 1),
        }
        if plan.robust_from == "first_solution":
            table[mode]["solved_under_noise"] = sum(1 for r in done if r.solved_under_noise)
    return table


def fisher(table: dict[str, dict[str, Any]], modes: tuple[str, ...]) -> dict[str, Any] | None:
    """Two-sided Fisher's exact test on solved / not solved between the first two modes."""
    if len(modes) < 2:
        return None
    from scipy.stats import fisher_exact

    a, b = (table[m] for m in modes[:2])
    if not a["runs_finished"] or not b["runs_finished"]:
        return None
    counts = [[a["solved"], a["runs_finished"] - a["solved"]], [b["solved"], b["runs_finished"] - b["solved"]]]
    res = fisher_exact(counts, alternative="two-sided")
    odds = float(res.statistic)
    return {"modes": list(modes[:2]), "table": counts, "odds_ratio": odds if np.isfinite(odds) else None,
            "p_value": float(res.pvalue), "alternative": "two-sided"}


def curves(plan: ExperimentPlan, runs: list[RunRecord], mode: str) -> dict[str, np.ndarray]:
    """Best-so-far fitness per generation (runs that stopped keep their last value) and the fraction of
    finished runs solved by each generation."""
    done = [r for r in runs if r.mode == mode and r.finished and r.generations]
    G = plan.generations
    if not done:
        return {"generation": np.arange(G), "best": np.zeros((0, G)), "solved_fraction": np.zeros(G)}
    best = np.stack([np.concatenate([r.best_ever, np.full(G - len(r.best_ever), r.best_ever[-1])])[:G]
                     for r in done])
    solved_by = np.array([[r.first_solved is not None and r.first_solved <= g for g in range(G)] for r in done])
    return {"generation": np.arange(G), "best": best, "solved_fraction": solved_by.mean(axis=0)}
