"""The map probes (`mahn-evo probe`) of many teams as one table: a row per team, a column per probe, the stages
completed of 9 (`*`: success); `turns` / `lengths`: probes of that kind where every robot reached its post (the
turn, the arm lengths handled), and in brackets where the whole protocol succeeded.
Usage: python probe_table.py OUT.csv LABEL=CHAMPION.json ...  (prints markdown)."""
from __future__ import annotations

import csv
import sys
from pathlib import Path

from mahn_evo.evaluation.probes import PROBES, all_posts, probe_team
from mahn_evo.training.champion import Champion


def main(out: str, teams: list[str]) -> None:
    names = [p.name for p in PROBES]
    rows = []
    for item in teams:
        label, _, path = item.partition("=")
        result = probe_team(Champion.load(Path(path)))
        rows.append([label, path] + [f"{r['stages']}{'*' if r['success'] else ''}" for r in result])
        for kind in ("turn", "length"):
            of = [r for r in result if r["kind"] == kind]
            rows[-1].append(f"{sum(all_posts(r) for r in of)} ({sum(r['success'] for r in of)})")
        print(f"{label}: turns {rows[-1][-2]}, lengths {rows[-1][-1]}", file=sys.stderr, flush=True)
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["team", "file", *names, "turns_of_4", "lengths_of_6"])  # "posts (whole protocol)"
        w.writerows(rows)
    print("| team | " + " | ".join(names) + " | turns of 4 | lengths of 6 |")
    print("|---" * (len(names) + 3) + "|")
    for r in rows:
        print(f"| {r[0]} | " + " | ".join(str(c) for c in r[2:]) + " |")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
