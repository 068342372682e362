"""Per solved run of a hardening experiment: the generations of its robust phase in which at least one team solved
every episode of the generation (log.csv `n_solved` > 0 after first solution + robust delay), the most teams that
did in one generation, and the last robust generation's best fitness.

Usage: python robust_phase.py EXPERIMENT_DIR  (e.g. runs/harden-branch-plain; reads runs/*/log.csv, summary.json,
config.json)
"""
from __future__ import annotations

import csv
import json
import sys
from pathlib import Path


def robust_phase(run: Path) -> dict | None:
    summary = json.loads((run / "summary.json").read_text())
    config = json.loads((run / "config.json").read_text())
    config = config.get("config", config)
    first = summary.get("first_solved_generation")
    if first is None:
        return None
    start = first + int(config.get("robust_delay", 0))
    with open(run / "log.csv") as f:
        rows = [r for r in csv.DictReader(f) if int(r["generation"]) > start]
    if not rows:
        return None
    return {"run": run.name, "first_solved": first, "robust_generations": len(rows),
            "generations_with_a_team_solving_all": sum(int(r["n_solved"]) > 0 for r in rows),
            "most_teams_solving_all": max(int(r["n_solved"]) for r in rows),
            "last_best_fitness": round(float(rows[-1]["best_fitness"]), 2)}


if __name__ == "__main__":
    for run in sorted(Path(sys.argv[1]).glob("runs/*")):
        if (run / "summary.json").exists():
            row = robust_phase(run)
            print(row if row else {"run": run.name, "solved": False})
