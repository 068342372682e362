"""Merge champion measures (docs/results/robustness/measure.py outputs) into paired.json and print the table of
README.md: each seed's robust champion beside the faithful experiment's champion of the same seed.

Usage: python docs/results/experiment_robust/paired.py MEASURES.json [MEASURES.json ...]
Rows are keyed by run name ("robust_s007", "faithful_s007"); a later file's row replaces an earlier one.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from mahn_evo.storage.files import atomic_write_json

HERE = Path(__file__).parent


def _cells(r: dict) -> str:
    emu = r["emulator_fitness"]
    seq = r.get("sequential_successes_by_map", {"plus": r["sequential_successes"]})
    asym = seq.get("asymmetric_plus")
    return (f"{r['training_fitness']:.1f} | {r['noise_free_fitness']:.1f} | {r['noisy_mean_fitness']:.1f} | "
            f"{r['noisy_solved_fraction']:.2f} | {min(emu):.1f}-{max(emu):.1f} | {seq['plus']}/10 | "
            f"{'-' if asym is None else f'{asym}/10'} | {r['tied_fraction']:.0%} / {r['flipped_decisions']}")


def main(files: list[str]) -> None:
    rows: dict[str, dict] = {}
    for f in files:
        data = json.loads(Path(f).read_text())
        for r in data["measures"]:
            rows[r["run"]] = r
    robust = {k.split("_s")[1] for k in rows if k.startswith("robust_")}
    keep = [k for k in rows if k.split("_s")[1] in robust]  # seeds with a robust run only
    ordered = [rows[k] for k in sorted(keep, key=lambda k: (k.split("_s")[1], k.split("_")[0] != "faithful"))]
    atomic_write_json(HERE / "paired.json", {
        "note": "champion.json of each run (the best team by training fitness), measured by "
                "docs/results/robustness/measure.py; faithful = docs/results/experiment/ (iros2011-multistep, "
                "noise-free), robust = this experiment; same seeds. Rows without sequential_successes_by_map were "
                "measured before the protocol ran on asymmetric_plus too.",
        "rows": ordered})
    print("| seed | training | noise-free | noisy mean (20) | noisy solved | emulator (3 seeds) | seq. noisy plus | "
          "seq. noisy asym. | exact ties / flips |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in ordered:
        kind, seed = r["run"].split("_s")
        print(f"| {int(seed)} {kind} | {_cells(r)} |")


if __name__ == "__main__":
    main(sys.argv[1:])
