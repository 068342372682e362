"""How each pilot run's robust phase went: the best team's score per robust generation, under the robot noise.

The score is the generation's robust fitness (the mean over the team's noisy training episodes, its noise-free one
and its sequential ones); a team that succeeds in every episode scores about 165.  The robust phase starts at the
run's first solution + robust_delay + 1 (mahn_evo.training.config.robust_phase_start), read from its log and config.

Usage: python docs/results/robot_pilot/robust_phase.py [--out DIR] RUN_DIR...
(writes robust_phase.csv and robust_phase.png into DIR, by default this folder; runs without a robust phase yet are
left out)
"""
from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from mahn_evo.training.config import robust_phase_start  # noqa: E402

HERE = Path(__file__).resolve().parent


def robust_series(run: Path) -> tuple[int, list[tuple[int, float]]]:
    """(seed, [(robust generation, best score)]) of one run folder."""
    config = json.loads((run / "config.json").read_text())
    with open(run / "log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    first = next((int(r["generation"]) for r in rows if r["solved"] == "True"), None)
    start = robust_phase_start(config["robust_from"], config["robust_delay"], first)
    if start is None:
        return config["seed"], []
    return config["seed"], [(int(r["generation"]) - start, float(r["best_fitness"]))
                            for r in rows if int(r["generation"]) >= start]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=HERE)
    ap.add_argument("runs", nargs="+", type=Path)
    args = ap.parse_args()
    series = {seed: s for seed, s in (robust_series(run) for run in args.runs) if s}
    with open(args.out / "robust_phase.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["seed", "robust_generation", "best_score"])
        for seed in sorted(series):
            w.writerows((seed, g, round(v, 3)) for g, v in series[seed])
    fig, ax = plt.subplots(figsize=(7, 4))
    for seed in sorted(series):
        g, v = zip(*series[seed])
        ax.plot(g, v, label=f"seed {seed}", lw=1)
    ax.axhline(100, color="grey", ls=":", lw=0.8)
    ax.set_xlabel("generation of the robust phase (robot noise)")
    ax.set_ylabel("best team's robust score")
    ax.set_ylim(0, 175)
    ax.legend(loc="lower right")
    ax.set_title("hardened-sequential with --noise robot: the robust phase")
    fig.tight_layout()
    fig.savefig(args.out / "robust_phase.png", dpi=110)
    for seed in sorted(series):
        last = series[seed][-10:]
        print(f"seed {seed}: {len(series[seed])} robust generations, best score of the last 10: "
              f"{min(v for _, v in last):.1f}-{max(v for _, v in last):.1f}")


if __name__ == "__main__":
    main()
