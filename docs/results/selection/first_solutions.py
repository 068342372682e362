"""Is a hardened run's robustness already in its first solution?

For each run folder: the team(s) archived at the first solved generation play 20 noisy sequential-protocol
episodes on plus and one on each of 20 of the run's plus variants in the compiled core (the selection study's keys
and episodes, `selection_study.core_successes`); printed as one JSON line per run.

    python docs/results/selection/first_solutions.py RUN_FOLDER [RUN_FOLDER ...]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from selection_study import FAMILY_OFFSET, STUDY_KEY, core_successes  # noqa: E402

from mahn_envs.maps import load_map  # noqa: E402
from mahn_envs.maps.variants import spread_variant  # noqa: E402
from mahn_evo.storage.files import read_versioned_json  # noqa: E402
from mahn_evo.training.champion import Champion  # noqa: E402
from mahn_evo.training.config import EvolutionConfig  # noqa: E402


def first_solutions(run: Path, episodes: int = 20) -> dict:
    archived = sorted((run / "archive").glob("solution_g*.json"))  # solution_gGGGGG_iIIII.json
    if not archived:
        return {"run": run.name, "first_solution": None}
    generation = archived[0].name.split("_")[1]
    files = [p for p in archived if p.name.split("_")[1] == generation]
    config = EvolutionConfig.from_saved(read_versioned_json(run / "config.json", "config"))
    ev = config.evaluation
    family = [spread_variant(config.seed, STUDY_KEY + FAMILY_OFFSET + i, ev.map_spread, ev.map_branch,
                             ev.branch_sides) for i in range(episodes)]
    teams = [Champion.load(p).controllers for p in files]
    on_plus = core_successes(config, teams, [load_map(config.map)] * episodes, STUDY_KEY)
    on_family = core_successes(config, teams, family, STUDY_KEY + FAMILY_OFFSET)
    return {"run": run.name, "first_solution": int(generation[1:]),
            "teams": [{"file": p.name, "plus_of_20": int(a), "variants_of_20": int(b)}
                      for p, a, b in zip(files, on_plus, on_family)]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="run folders")
    for run in ap.parse_args().runs:
        print(json.dumps(first_solutions(run)), flush=True)


if __name__ == "__main__":
    main()
