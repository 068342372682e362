"""The standard-geometry comparison of issue 12, step 3b: NEAT-direct against HyperNEAT, 15 seeds each.

Why a script and not `mahn-baselines compare`: the HyperNEAT standard runs' per-generation logs were not kept, only
their rows in the experiments' runs.csv (solved, generations to solve, best fitness), which is all this table
needs.  Reads docs/results/baselines/fair_runs/neat_direct_standard_seed*/summary.json and the standard rows of
docs/results/experiment_faithful/runs.csv and docs/results/experiment/runs.csv; prints the markdown table.

    python docs/results/baselines/fair_neat_direct_standard/table.py
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from baselines.comparison.stats import fisher_solved, iqm, iqm_ci

RESULTS = Path(__file__).resolve().parents[2]
DIRECT = "NEAT-direct, standard"


def direct_runs() -> list[dict]:
    """One row per NEAT-direct standard run: seed, solved, generations to solve, best fitness.  Its summary names
    the first solution's generation index; the experiments count generations evaluated up to and including it."""
    rows = []
    for path in sorted((RESULTS / "baselines" / "fair_runs").glob("neat_direct_standard_seed*/summary.json")):
        s = json.loads(path.read_text())
        index = s["first_solved_generation"]
        rows.append({"seed": s["seed"], "solved": bool(s["solved"]), "first": None if index is None else index + 1,
                     "best": float(s["best_fitness"])})
    return sorted(rows, key=lambda r: r["seed"])


def experiment_runs(folder: str) -> list[dict]:
    """The standard-mode rows of an experiment's runs.csv, in the same form."""
    with open(RESULTS / folder / "runs.csv", newline="") as f:
        return [{"seed": int(r["seed"]), "solved": r["solved"] == "True",
                 "first": int(r["generations_to_solve"]) if r["generations_to_solve"] else None,
                 "best": float(r["best_fitness"])} for r in csv.DictReader(f) if r["mode"] == "standard"]


def main() -> None:
    methods = {DIRECT: direct_runs(),
               "HyperNEAT, standard, faithful (`--preset iros2011-multistep`)": experiment_runs("experiment_faithful"),
               "HyperNEAT, standard, chosen (`--preset best-restarts`)": experiment_runs("experiment")}
    direct = methods[DIRECT]
    k_direct = sum(r["solved"] for r in direct)
    print("| method | runs | solved (seed: generations to solve) | IQM of best fitness (95 % bootstrap CI) "
          "| Fisher p against NEAT-direct |")
    print("|---|---|---|---|---|")
    for name, runs in methods.items():
        best = np.array([r["best"] for r in runs])
        lo, hi = iqm_ci(best)
        k = sum(r["solved"] for r in runs)
        which = ", ".join(f"{r['seed']}: {r['first']}" for r in runs if r["solved"])
        p = "–" if name == DIRECT else f"{fisher_solved(k, len(runs), k_direct, len(direct)):.2f}"
        print(f"| {name} | {len(runs)} | {k}/{len(runs)} ({which}) | {iqm(best):.1f} ({lo:.1f}-{hi:.1f}) | {p} |")


if __name__ == "__main__":
    main()
