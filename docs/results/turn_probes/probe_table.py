"""The map probes (`mahn-evo probe`) of many teams as one table: a row per team, a column per probe, the stages
completed of 9 (`*`: success).  Usage: python probe_table.py OUT.csv LABEL=CHAMPION.json ...  (prints markdown)."""
from __future__ import annotations

import csv
import sys
from pathlib import Path

from mahn_evo.evaluation.probes import PROBES, probe_team
from mahn_evo.training.champion import Champion


def main(out: str, teams: list[str]) -> None:
    names = [p.name for p in PROBES]
    rows = []
    for item in teams:
        label, _, path = item.partition("=")
        result = probe_team(Champion.load(Path(path)))
        rows.append([label, path] + [f"{r['stages']}{'*' if r['success'] else ''}" for r in result])
        turns = sum(r["success"] for r in result if r["kind"] == "turn")
        lengths = sum(r["success"] for r in result if r["kind"] == "length")
        rows[-1] += [turns, lengths]
        print(f"{label}: turns {turns}/4, lengths {lengths}/6", file=sys.stderr, flush=True)
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["team", "file", *names, "turns_of_4", "lengths_of_6"])
        w.writerows(rows)
    print("| team | " + " | ".join(names) + " | turns | lengths |")
    print("|---" * (len(names) + 3) + "|")
    for r in rows:
        print(f"| {r[0]} | " + " | ".join(str(c) for c in r[2:]) + " |")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
