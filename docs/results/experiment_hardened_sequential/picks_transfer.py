"""The transfer test of every run's final-validation pick, not only the report's five: which runs' picks pass the
noisy sequential protocol on both maps, beside the validation successes they were picked by.

    python docs/results/experiment_hardened_sequential/picks_transfer.py runs/rob1000 > picks.jsonl

One JSON line per run: the pick's file, its final validation's sequential successes on the map and on the run's
plus variants, and the success fractions of the report's transfer test (`transfer_tests`: 10 noisy sequential
episodes per map in pymunk, the experiment's seed), so the table in README.md can be checked against the runs.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.experiment.transfer import final_pick, robust_on_every_map, transfer_tests
from mahn_evo.training.champion import Champion


def main(experiment: Path) -> None:
    plan = ExperimentPlan.load(experiment)
    for run in sorted((experiment / "runs").glob("*_s*")):
        chosen = final_pick(run)
        if chosen is None:
            print(json.dumps({"run": run.name, "pick": None}), flush=True)
            continue
        transfer = transfer_tests(Champion.load(run / chosen["file"]), plan)
        print(json.dumps({"run": run.name, "pick": chosen["file"],
                          "validation_plus": chosen.get("sequential_successes"),
                          "validation_variants": chosen.get("family_successes"),
                          "plus": transfer["plus"]["sequential_noisy"]["success_fraction"],
                          "asymmetric_plus": transfer["asymmetric_plus"]["sequential_noisy"]["success_fraction"],
                          "robust": robust_on_every_map(transfer)}), flush=True)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    main(Path(sys.argv[1]))
