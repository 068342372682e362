"""Merge champion measures (measure.py outputs) into an experiment's paired.json and print the table of its
README.md: each seed's champion beside the faithful experiment's champion of the same seed.

Usage: python docs/results/robustness/paired.py EXPERIMENT_DOCS_DIR LABEL MEASURES.json [MEASURES.json ...]
e.g. `paired.py docs/results/experiment_robust robust m1.json m2.json`.  Rows are keyed by run name
("robust_s007", "faithful_s007"); a later file's row replaces an earlier one; seeds without a LABEL row are left out.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from mahn_evo.storage.files import atomic_write_json


def _cells(r: dict) -> str:
    emu = r["emulator_fitness"]
    seq = r.get("sequential_successes_by_map", {"plus": r["sequential_successes"]})
    asym = seq.get("asymmetric_plus")
    return (f"{r['training_fitness']:.1f} | {r['noise_free_fitness']:.1f} | {r['noisy_mean_fitness']:.1f} | "
            f"{r['noisy_solved_fraction']:.2f} | {min(emu):.1f}-{max(emu):.1f} | {seq['plus']}/10 | "
            f"{'-' if asym is None else f'{asym}/10'} | {r['tied_fraction']:.0%} / {r['flipped_decisions']}")


def main(out_dir: str, label: str, files: list[str]) -> None:
    rows: dict[str, dict] = {}
    for f in files:
        data = json.loads(Path(f).read_text())
        for r in data["measures"]:
            rows[r["run"]] = r
    measured = {k.split("_s")[1] for k in rows if k.startswith(f"{label}_")}
    keep = [k for k in rows if k.split("_s")[1] in measured and k.split("_s")[0] in (label, "faithful")]
    ordered = [rows[k] for k in sorted(keep, key=lambda k: (k.split("_s")[1], k.split("_")[0] != "faithful"))]
    atomic_write_json(Path(out_dir) / "paired.json", {
        "note": "champion.json of each run (the best team by training fitness), measured by "
                "docs/results/robustness/measure.py; faithful = docs/results/experiment_faithful/ (iros2011-multistep, "
                f"noise-free), {label} = this experiment; same seeds. Rows without sequential_successes_by_map "
                "were measured before the protocol ran on asymmetric_plus too.",
        "rows": ordered})
    print("| seed | training | noise-free | noisy mean (20) | noisy solved | emulator (3 seeds) | seq. noisy plus | "
          "seq. noisy asym. | exact ties / flips |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in ordered:
        kind, seed = r["run"].split("_s")
        print(f"| {int(seed)} {kind} | {_cells(r)} |")


if __name__ == "__main__":
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
