"""Do the published teams that survive the transfer test decide by fewer float32 output ties?

For every experiment folder under docs/results with a results.json and champions/: each most general team's
decision margins (`mahn-evo eval --margins`: training protocol on plus, noise-free, one episode: the fraction of
decisions taken by an exact tie of the top two outputs, and how many decisions inputs jittered by +-1e-4 flip)
beside its transfer test (noisy sequential successes of 10 on plus and on asymmetric_plus).  Teams that appear in
several experiments (the same controllers) count once.

    python docs/results/decision_ties/ties_vs_transfer.py > docs/results/decision_ties/teams.csv
    python docs/results/decision_ties/ties_vs_transfer.py --summary docs/results/decision_ties/teams.csv
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import json
import sys
from pathlib import Path

import numpy as np
from scipy import stats

from mahn_evo.evaluation.margins import decision_margins
from mahn_evo.training.champion import Champion

RESULTS = Path(__file__).resolve().parents[1]
FIELDS = ("experiment", "run", "team", "plus_of_10", "asymmetric_plus_of_10", "robust", "tied_fraction",
          "near_tie_fraction", "flipped", "median_top_output")


def team_digest(champion: Champion) -> str:
    """The controllers' bytes: equal digests, the same team."""
    c = champion.controllers
    h = hashlib.sha256()
    for a in (c.w_ih, c.w_hh, c.w_ho, c.b_h, c.b_o):
        h.update(np.ascontiguousarray(a, dtype=np.float32).tobytes())
    h.update(c.decision.encode())
    return h.hexdigest()[:16]


def rows() -> list[dict]:
    out, seen = [], set()
    for res in sorted(RESULTS.glob("**/results.json")):
        data = json.loads(res.read_text())
        for picks in (data.get("most_general") or {}).values():
            for pick in picks:
                path = res.parent / "champions" / f"{pick['run']}.json"
                try:
                    plus = pick["transfer"]["plus"]["sequential_noisy"]["success_fraction"]
                    asym = pick["transfer"]["asymmetric_plus"]["sequential_noisy"]["success_fraction"]
                except (KeyError, TypeError):
                    continue  # an experiment reported before the noisy sequential test existed
                if not path.exists():
                    continue
                champion = Champion.load(path)
                digest = team_digest(champion)
                if digest in seen:
                    continue
                seen.add(digest)
                m = decision_margins(champion)
                out.append({"experiment": str(res.parent.relative_to(RESULTS)), "run": pick["run"], "team": digest,
                            "plus_of_10": round(10 * plus), "asymmetric_plus_of_10": round(10 * asym),
                            "robust": int(plus >= 0.8 and asym >= 0.8), "tied_fraction": round(m["tied_fraction"], 4),
                            "near_tie_fraction": round(m["near_tie_fraction"], 4), "flipped": m["flipped"],
                            "median_top_output": f"{m['median_top_output']:.3g}"})
    return out


def summary(table: list[dict]) -> str:
    robust = np.array([int(r["robust"]) for r in table], dtype=bool)
    lines = [f"{len(table)} distinct teams, {robust.sum()} robust (8+ of 10 on both maps)"]
    for field in ("tied_fraction", "flipped"):
        x = np.array([float(r[field]) for r in table])
        u = stats.mannwhitneyu(x[robust], x[~robust])
        lines.append(f"{field}: median {np.median(x[robust]):.3g} robust, {np.median(x[~robust]):.3g} not; "
                     f"Mann-Whitney p = {u.pvalue:.2g}")
    both = np.array([min(int(r["plus_of_10"]), int(r["asymmetric_plus_of_10"])) for r in table])
    rho = stats.spearmanr([float(r["tied_fraction"]) for r in table], both)
    lines.append(f"Spearman tied_fraction vs the weaker map's successes: rho = {rho.statistic:.2f}, "
                 f"p = {rho.pvalue:.2g}")
    zero = np.array([int(r["flipped"]) == 0 for r in table])
    lines.append(f"teams with no decision flipped: {zero.sum()}, of them robust {(zero & robust).sum()}; "
                 f"teams with flips: {(~zero).sum()}, robust {(~zero & robust).sum()}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--summary", type=Path, help="summarise a table written before instead of measuring")
    args = ap.parse_args()
    if args.summary:
        with open(args.summary, newline="") as f:
            print(summary(list(csv.DictReader(f))))
        return
    writer = csv.DictWriter(sys.stdout, fieldnames=FIELDS)
    writer.writeheader()
    writer.writerows(rows())


if __name__ == "__main__":
    main()
