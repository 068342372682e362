"""The direct-encoding controls of issue 12 against HyperNEAT at one budget: 2.05 G robot-steps per run.

Why a script and not `mahn-baselines compare`: the HyperNEAT runs' per-generation logs were not kept, only their
rows in the experiments' runs.csv (solved, generations to solve, best fitness), which is all this table needs.
The budget of a HyperNEAT run is its teams scored x 1364 ticks x 3 robots: 500 teams a generation, x 3 with
`--symmetry best` (every genome is also scored in its two mirror readings), so the chosen configuration
(`--preset best-restarts`) spends 2.05 G robot-steps in 333 generations, the faithful one in 1000.  A run counts as
solved within the budget when its first solution came before it was spent.

Reads docs/results/baselines/fair_runs/{ipop_situational,ipop_standard,neat_direct_standard}_seed*/summary.json,
the curves of docs/results/baselines/fair_neat_direct/comparison.json (NEAT-direct situational) and the rows of
docs/results/experiment_faithful/runs.csv and docs/results/experiment/runs.csv; prints the markdown table.

    python docs/results/baselines/fair_ipop/table.py
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from baselines.comparison.stats import fisher_solved, iqm, iqm_ci

RESULTS = Path(__file__).resolve().parents[2]
ROBOT_STEPS = 1364 * 3  # per team scored
BUDGET = 500_000 * ROBOT_STEPS  # the direct controls' budget: 500,000 teams, as 1000 HyperNEAT generations of 500
REFERENCE = "HyperNEAT, faithful (`--preset iros2011-multistep`)"


def summary_runs(pattern: str) -> list[dict]:
    """One row per direct run (its summary.json): solved within the budget, robot-steps to solve, best fitness."""
    rows = []
    for path in sorted((RESULTS / "baselines" / "fair_runs").glob(f"{pattern}_seed*/summary.json")):
        s = json.loads(path.read_text())
        to_solve = None
        if s["solved"]:
            with open(path.parent / "log.csv", newline="") as f:
                log = {int(r["generation"]): int(r["evaluations"]) for r in csv.DictReader(f)}
            to_solve = log[s["first_solved_generation"]] * ROBOT_STEPS
        rows.append({"seed": s["seed"], "to_solve": to_solve, "best": float(s["best_fitness"])})
    return rows


def neat_direct_situational() -> list[dict]:
    """NEAT-direct situational (fair_neat_direct): each run's curve gives its budget at the first solution."""
    data = json.loads((RESULTS / "baselines" / "fair_neat_direct" / "comparison.json").read_text())
    rows = []
    for c in data["curves"]:
        if not c["method"].startswith("neat_direct"):
            continue
        solved = [b for b, ok in zip(c["budget"], c["solved"]) if ok]
        rows.append({"seed": c["seed"], "to_solve": solved[0] if solved else None, "best": float(max(c["fitness"]))})
    return rows


def hyperneat_runs(folder: str, mode: str, teams_per_generation: int) -> list[dict]:
    """The `mode` rows of an experiment's runs.csv; robot-steps to solve from the generations to solve."""
    with open(RESULTS / folder / "runs.csv", newline="") as f:
        return [{"seed": int(r["seed"]), "best": float(r["best_fitness"]),
                 "to_solve": int(r["generations_to_solve"]) * teams_per_generation * ROBOT_STEPS
                 if r["generations_to_solve"] else None}
                for r in csv.DictReader(f) if r["mode"] == mode]


def main() -> None:
    for mode in ("situational", "standard"):
        methods = {REFERENCE: hyperneat_runs("experiment_faithful", mode, 500),
                   "HyperNEAT, chosen (`--preset best-restarts`, 3 readings per genome)":
                       hyperneat_runs("experiment", mode, 1500),
                   "IPOP-CMA-ES, direct": summary_runs(f"ipop_{mode}"),
                   "NEAT-direct": neat_direct_situational() if mode == "situational"
                   else summary_runs("neat_direct_standard")}
        ref = methods[REFERENCE]
        k_ref = sum(r["to_solve"] is not None and r["to_solve"] <= BUDGET for r in ref)
        print(f"\n{mode}\n")
        print("| method | runs | solved within 2.05 G robot-steps (seeds) | median G robot-steps to solve (those) "
              "| IQM of final best fitness (95 % bootstrap CI) | Fisher p against faithful HyperNEAT |")
        print("|---|---|---|---|---|---|")
        for name, runs in methods.items():
            within = sorted((r for r in runs if r["to_solve"] is not None and r["to_solve"] <= BUDGET),
                            key=lambda r: r["seed"])
            steps = [r["to_solve"] / 1e9 for r in within]
            median = f"{np.median(steps):.2f}" if steps else "–"
            best = np.array([r["best"] for r in runs])
            lo, hi = iqm_ci(best)
            p = "–" if name == REFERENCE else f"{fisher_solved(len(within), len(runs), k_ref, len(ref)):.3g}"
            seeds = ", ".join(str(r["seed"]) for r in within)
            print(f"| {name} | {len(runs)} | {len(within)}/{len(runs)} ({seeds}) | {median} | {iqm(best):.1f} "
                  f"({lo:.1f}-{hi:.1f}) | {p} |")


if __name__ == "__main__":
    main()
