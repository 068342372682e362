"""Experiments in progress, kept in the repository between sessions so that a change of machine loses no run.

A session's background runs end with it, and the host's disk may not come back (stop 45 lost the folders of four
experiments that way). Each session parks the experiments it ran before it stops and restores them at its start;
runs resume from their checkpoints bit for bit (the trainer's resume is exact, also on another host).

  python docs/results/in_progress/park.py park EXPERIMENT_DIR [NAME]
      copy the experiment (experiment.json and every run folder's files but locks, pictures and temporary files)
      to docs/results/in_progress/NAME/ (default: the folder's name), replacing the parked copy; every
      checkpoint is read back through its digest first, so a damaged file is never parked
  python docs/results/in_progress/park.py restore NAME EXPERIMENT_DIR
      copy a parked experiment back; refused when a run there is further along than its parked copy
  python docs/results/in_progress/park.py list
      each parked experiment's runs: generations, finished or not
"""
from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.experiment.table import load_runs
from mahn_evo.storage.files import read_checked_json

HERE = Path(__file__).resolve().parent
#: what a run writes that a resume does not need or that belongs to one machine
SKIPPED = (".mahn.lock", "*.png", "*.gif", "*.tmp", ".*.tmp*")


def generations(run: Path) -> int:
    """Generations a run folder has finished (0 without a checkpoint); a damaged checkpoint is an error."""
    ckpt = run / "checkpoint.json"
    if not ckpt.exists():
        return 0
    return int(read_checked_json(ckpt, "checkpoint")["population"]["generation"])


def runs(experiment: Path) -> list[Path]:
    return sorted(p for p in (experiment / "runs").iterdir() if p.is_dir()) if (experiment / "runs").is_dir() else []


def park(experiment: Path, name: str) -> Path:
    if not (experiment / "experiment.json").exists():
        raise ValueError(f"{str(experiment)!r} holds no experiment (experiment.json missing)")
    for run in runs(experiment):
        generations(run)  # refuses a damaged checkpoint before anything is replaced
    target = HERE / name
    staged = HERE / f".{name}.staged"
    shutil.rmtree(staged, ignore_errors=True)
    shutil.copytree(experiment, staged, ignore=shutil.ignore_patterns(*SKIPPED))
    shutil.rmtree(target, ignore_errors=True)
    staged.rename(target)
    return target


def restore(name: str, experiment: Path) -> None:
    source = HERE / name
    if not (source / "experiment.json").exists():
        raise ValueError(f"no parked experiment {name!r} in {HERE}")
    for run in runs(source):
        here = experiment / "runs" / run.name
        if here.exists() and generations(here) > generations(run):
            raise ValueError(f"{str(here)!r} is at generation {generations(here)}, its parked copy at "
                             f"{generations(run)}: restoring would lose generations (park it first)")
    shutil.copytree(source, experiment, dirs_exist_ok=True)


def listing() -> list[dict]:
    """Every parked run, finished or not by its experiment's plan (mahn_evo.experiment.table.load_runs)."""
    out = []
    for exp in sorted(p for p in HERE.iterdir() if (p / "experiment.json").exists()):
        for record in load_runs(ExperimentPlan.load(exp), exp):
            if record.folder.exists():
                out.append({"experiment": exp.name, "run": record.name, "generations": generations(record.folder),
                            "finished": record.finished})
    return out


def main(argv: list[str]) -> int:
    try:
        if len(argv) in (2, 3) and argv[0] == "park":
            exp = Path(argv[1])
            print(park(exp, argv[2] if len(argv) == 3 else exp.resolve().name))
            return 0
        if len(argv) == 3 and argv[0] == "restore":
            restore(argv[1], Path(argv[2]))
            return 0
        if argv == ["list"]:
            for row in listing():
                print(json.dumps(row))
            return 0
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
