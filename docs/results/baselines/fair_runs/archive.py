"""Keep finished budget runs of issue 12 here, without their checkpoints, and print their table rows.

Why: run folders do not survive this project's sessions; what a finished run says (its log, summary, config and
best controllers) is small and is what `mahn-baselines compare --no-train --evo-runs ...` reads.  A run that has
not finished its budget is refused, so a partial run is never kept as if it had finished.

Usage: python docs/results/baselines/fair_runs/archive.py COMMIT RUN_DIR ...
(copies RUN_DIR/{log.csv,summary.json,config.json,best_controllers.json} to fair_runs/<name of RUN_DIR>/ and prints
the README row of each; the rows go into README.md's table by hand, before the paragraph under it)
"""
from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
FILES = ("log.csv", "summary.json", "config.json", "best_controllers.json")


def row(name: str, summary: dict, config: dict, commit: str) -> str:
    """The README row of one IPOP-CMA-ES or CMA-ES run."""
    cmd = (f"`OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 mahn-baselines cmaes --mode {config['mode']} --generations "
           f"{config['generations']} --popsize {config['popsize']}"
           + (f" --restart-patience {config['restart_patience']}" if config.get("restart_patience") else "")
           + f" --seed {config['seed']} --out runs/fair/{name} --resume` (commit {commit})")
    if summary["solved"]:
        what = (f"solved, first solution at generation index {summary['first_solved_generation']}, best "
                f"{summary['best_fitness']:.2f}")
    else:
        what = f"not solved, best {summary['best_fitness']:.2f}"
    searches = summary.get("searches") or []
    if searches:
        pops = ", ".join(str(s["popsize"]) for s in searches)
        what += (f"; {summary['evaluations']} teams in {summary['generations']} generations, {len(searches)} "
                 f"search{'es' if len(searches) > 1 else ''} (popsizes {pops})")
    return f"| [`{name}/`]({name}/) | {cmd} | {what} | {summary['cpu_seconds']:.0f} |"


def main() -> None:
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    commit = sys.argv[1]
    for run in map(Path, sys.argv[2:]):
        missing = [f for f in FILES if not (run / f).is_file()]
        if missing:
            sys.exit(f"{run}: not a finished run (missing {', '.join(missing)})")
        summary = json.loads((run / "summary.json").read_text())
        config = json.loads((run / "config.json").read_text())
        budget = int(config["generations"]) * int(config["popsize"])
        searches = summary.get("searches") or [{"popsize": config["popsize"]}]
        if summary["evaluations"] + int(searches[-1]["popsize"]) <= budget:  # the run's own rule for one more
            sys.exit(f"{run}: {summary['evaluations']} of {budget} teams evaluated and room for another "
                     f"generation: not finished, not kept")
        dest = HERE / run.name
        dest.mkdir(exist_ok=True)
        for f in FILES:
            shutil.copyfile(run / f, dest / f)
        print(row(run.name, summary, config, commit))


if __name__ == "__main__":
    main()
