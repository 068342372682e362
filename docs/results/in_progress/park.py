"""Experiments in progress, kept in the repository between sessions so that a change of machine loses no run.

A session's background runs end with it, and the host's disk may not come back (stop 45 lost the folders of four
experiments that way). Each session parks the experiments it ran before it stops and restores them at its start;
runs resume from their checkpoints bit for bit (the trainer's resume is exact, also on another host).

  python docs/results/in_progress/park.py park EXPERIMENT_DIR [NAME] [--force]
      copy the experiment (experiment.json and each run folder's files but locks, pictures and temporary files)
      into docs/results/in_progress/NAME/ (default: the folder's name), run by run: a parked run the folder does
      not hold stays parked, and a parked run further along than the folder's is kept (--force replaces it);
      every checkpoint copied is read back through its digest, and a run in use (its lock held) is refused
  python docs/results/in_progress/park.py restore NAME EXPERIMENT_DIR
      copy a parked experiment back, run by run; a run that is as far along here or further (its report files, such
      as the final validation's, are not in the parked copy), or in use, is left as it is
  python docs/results/in_progress/park.py park-lean FOLDER [NAME]
  python docs/results/in_progress/park.py restore-lean NAME FOLDER
      the same for issue 12's lean PPO runs (`mahn-baselines lean --out FOLDER/RUN`: the run folders directly in
      FOLDER, default NAME the folder's name), their progress counted in updates; the tuning studies are kept
      apart (docs/results/baselines/fair_runs/)
  python docs/results/in_progress/park.py park-all RUNS_DIR
      what a session parks before it stops, in one step: every experiment of RUNS_DIR that is parked already (a new
      one is parked the first time by name), the lean PPO runs of RUNS_DIR/fair, and the tuning journals of
      RUNS_DIR/fair/tune_* into docs/results/baselines/fair_runs/ (a journal with fewer lines than the kept one,
      e.g. a fresh host's, is never copied over it)
  python docs/results/in_progress/park.py finished RUN_FOLDER BUDGET
      exit status 0 when the lean run has reached BUDGET robot-steps, here or in its copy kept in
      docs/results/baselines/fair_runs/ (queue.sh asks before it starts a final run), else 1
  python docs/results/in_progress/park.py list
      each parked experiment's runs: generations, finished or not; each parked lean run's updates
"""
from __future__ import annotations

import json
import re
import shutil
import sys
import zipfile
from collections.abc import Callable, Collection
from pathlib import Path

# mahn_evo is imported where it is used: importing it takes seconds (it loads the env), and queue.sh calls
# `finished`, which needs none of it, for each final run it considers

HERE = Path(__file__).resolve().parent
#: what a run writes that a resume does not need or that belongs to one machine
SKIPPED = (".mahn.lock", "*.png", "*.gif", "*.tmp", ".*.tmp*")
#: a parked experiment's name: one folder inside HERE, never a path
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")


def generations(run: Path) -> int:
    """Generations a run folder has finished (0 without a checkpoint); a damaged checkpoint is an error."""
    from mahn_evo.storage.files import read_checked_json

    ckpt = run / "checkpoint.json"
    if not ckpt.exists():
        return 0
    return int(read_checked_json(ckpt, "checkpoint")["population"]["generation"])


def updates(run: Path) -> int:
    """Updates a lean PPO run folder has finished (0 without a checkpoint); a damaged checkpoint, or one whose
    weights file is missing or unreadable, is an error."""
    from mahn_evo.storage.files import read_versioned_json

    ckpt = run / "checkpoint.json"
    if not ckpt.exists():
        return 0
    state = read_versioned_json(ckpt, "lean_checkpoint")
    weights = run / str(state["weights"])
    try:
        with zipfile.ZipFile(weights) as z:  # an .npz: every member read back through its CRC
            bad = z.testzip()
    except (OSError, zipfile.BadZipFile) as exc:
        raise ValueError(f"lean run {str(run)!r}: its weights {weights.name} cannot be read ({exc})") from exc
    if bad is not None:
        raise ValueError(f"lean run {str(run)!r}: its weights {weights.name} are damaged ({bad})")
    return int(state["update"])


def lean_runs(folder: Path) -> list[Path]:
    """The lean PPO run folders directly in `folder` (config.json of kind lean_config)."""
    out = []
    for p in sorted(folder.iterdir()) if folder.is_dir() else []:
        try:
            kind = json.loads((p / "config.json").read_text(encoding="utf-8")).get("kind")
        except (OSError, ValueError, AttributeError):
            continue
        if kind == "lean_config" and not p.name.startswith("."):
            out.append(p)
    return out


def runs(experiment: Path) -> list[Path]:
    """The run folders of an experiment (not a staged copy left by an interrupted park or restore)."""
    if not (experiment / "runs").is_dir():
        return []
    return sorted(p for p in (experiment / "runs").iterdir() if p.is_dir() and not p.name.startswith("."))


def parked_folder(name: str) -> Path:
    if not NAME.fullmatch(name):
        raise ValueError(f"a parked experiment's name is letters, digits, '_', '-' and '.', got {name!r}")
    return HERE / name


def _copy_run(run: Path, target: Path, progress: Callable[[Path], int]) -> None:
    """Copy a run folder over `target` through a staged copy whose checkpoint is read back first."""
    staged = target.parent / f".{target.name}.staged"
    shutil.rmtree(staged, ignore_errors=True)
    shutil.copytree(run, staged, ignore=shutil.ignore_patterns(*SKIPPED))
    try:
        progress(staged)
    except ValueError:
        shutil.rmtree(staged)
        raise
    shutil.rmtree(target, ignore_errors=True)
    staged.rename(target)


def _park_runs(found: list[Path], target: Path, progress: Callable[[Path], int], unit: str, force: bool,
               log) -> None:
    """Copy each run of `found` into target/<name>, unless the parked copy is further along (`force` replaces
    it); `progress` counts a run's checkpointed steps in `unit` (and checks the checkpoint)."""
    from mahn_evo.storage.folder_lock import lock_holder

    busy = [run.name for run in found if lock_holder(run) is not None]
    if busy:
        raise ValueError(f"run(s) {busy} of {str(found[0].parent)!r} are in use: stop them before parking")
    target.mkdir(parents=True, exist_ok=True)
    for run in found:
        kept = target / run.name
        if kept.exists() and not force:
            p_kept, p_run = progress(kept), progress(run)  # each checkpoint read (and checked) once
            if p_kept > p_run:
                log(f"{run.name}: the parked copy is further along ({p_kept} > {p_run} {unit}): kept (--force "
                    "replaces it)")
                continue
        _copy_run(run, kept, progress)


def _restore_runs(found: list[Path], dest: Path, progress: Callable[[Path], int], unit: str, log) -> None:
    """Copy each parked run of `found` into dest/<name>, but for a run in use here, one further along (left as it
    is) and one as far along (left as it is, the parked files it lacks copied in: e.g. the report's final
    validation of a finished run is here, not in its parked copy)."""
    from mahn_evo.storage.folder_lock import lock_holder

    dest.mkdir(parents=True, exist_ok=True)
    for run in found:
        here = dest / run.name
        if here.exists() and lock_holder(here) is not None:
            log(f"{run.name}: in use here, left as it is")
            continue
        if here.exists():
            p_here, p_parked = progress(here), progress(run)  # each checkpoint read (and checked) once
            if p_here > p_parked:
                log(f"{run.name}: further along here ({p_here} > {p_parked} {unit}), left as it is")
                continue
            if p_here == p_parked:
                added = _fill_missing(run, here)
                log(f"{run.name}: as far along here ({p_here} {unit}), left as it is"
                    + (f" ({added} parked file(s) it lacked copied)" if added else ""))
                continue
        _copy_run(run, here, progress)


def _fill_missing(run: Path, here: Path) -> int:
    """Copy the files of parked `run` that `here` lacks (never one it has); returns how many."""
    added = 0
    for path in sorted(run.rglob("*")):
        target = here / path.relative_to(run)
        if path.is_file() and not target.exists() and not any(path.match(p) for p in SKIPPED):
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, target)
            added += 1
    return added


def park(experiment: Path, name: str, force: bool = False, log=print) -> Path:
    from mahn_evo.experiment.plan import PLAN_FILE

    target = parked_folder(name)
    if not (experiment / PLAN_FILE).exists():
        raise ValueError(f"{str(experiment)!r} holds no experiment ({PLAN_FILE} missing)")
    found = runs(experiment)
    if found:
        _park_runs(found, target / "runs", generations, "generations", force, log)
    (target / "runs").mkdir(parents=True, exist_ok=True)
    shutil.copy2(experiment / PLAN_FILE, target / PLAN_FILE)
    return target


def restore(name: str, experiment: Path, log=print) -> None:
    from mahn_evo.experiment.plan import PLAN_FILE

    source = parked_folder(name)
    if not (source / PLAN_FILE).exists():
        raise ValueError(f"no parked experiment {name!r} in {HERE}")
    (experiment / "runs").mkdir(parents=True, exist_ok=True)
    if not (experiment / PLAN_FILE).exists():
        shutil.copy2(source / PLAN_FILE, experiment / PLAN_FILE)
    _restore_runs(runs(source), experiment / "runs", generations, "generations", log)


def park_lean(folder: Path, name: str, force: bool = False, log=print, skip: Collection[str] = ()) -> Path:
    """`park` for the lean PPO runs in `folder` (but those named in `skip`): progress in updates, a run in use
    refused."""
    found = [run for run in lean_runs(folder) if run.name not in skip]
    if not found:
        raise ValueError(f"{str(folder)!r} holds no lean PPO run folder")
    target = parked_folder(name)
    _park_runs(found, target, updates, "updates", force, log)
    return target


def restore_lean(name: str, folder: Path, log=print) -> None:
    """`restore` for parked lean PPO runs (see _restore_runs)."""
    found = lean_runs(parked_folder(name))
    if not found:
        raise ValueError(f"no parked lean PPO runs {name!r} in {HERE}")
    _restore_runs(found, folder, updates, "updates", log)


#: where issue 12's finished runs and tuning journals are kept (docs/results/baselines/fair_runs/README.md)
FAIR_RUNS = HERE.parent / "baselines" / "fair_runs"
TUNING_FILES = ("study.jsonl", "best.json", "tuning_cost.json")


def summary_steps(run: Path) -> float:
    """Robot-steps a lean run folder's summary.json records (a run writes it when it reaches its budget); 0 when
    it has none or it cannot be read."""
    try:
        return float(json.loads((run / "summary.json").read_text(encoding="utf-8"))["steps"])
    except (OSError, ValueError, KeyError, TypeError):
        return 0.0


def kept(run: Path) -> bool:
    """Whether lean run `run` is finished and kept in FAIR_RUNS (archive.py keeps only finished runs, with their
    summary; the parked copy is then removed)."""
    return summary_steps(FAIR_RUNS / run.name) > 0


def finished(run: Path, budget: float) -> bool:
    """Whether lean run `run` has reached `budget` robot-steps, here or in its kept copy: the rule by which
    queue.sh's final_pool leaves a run alone (park_all asks only `kept`: a run finished here but not yet kept is
    parked, so it is not lost)."""
    return max(summary_steps(run), summary_steps(FAIR_RUNS / run.name)) >= budget


def park_tuning(fair: Path, log=print) -> list[Path]:
    """Copy each RUNS/fair/tune_*/ journal (and its best.json, tuning_cost.json) into FAIR_RUNS, unless the kept
    journal has more lines (trials recorded) than this one; returns the files written."""
    written = []
    for study in sorted(fair.glob("tune_*/study.jsonl")):
        kept = FAIR_RUNS / study.parent.name
        lines = len(study.read_text(encoding="utf-8").splitlines())
        if (kept / "study.jsonl").exists():
            kept_lines = len((kept / "study.jsonl").read_text(encoding="utf-8").splitlines())
            if kept_lines > lines:
                log(f"{study.parent.name}: the kept journal is further along ({kept_lines} > {lines} lines): kept")
                continue
        kept.mkdir(parents=True, exist_ok=True)
        for name in TUNING_FILES:
            if (study.parent / name).exists():
                shutil.copy2(study.parent / name, kept / name)
                written.append(kept / name)
    return written


def park_all(runs_dir: Path, log=print) -> None:
    """`park` every experiment of runs_dir already parked, `park_lean` its fair/ runs, `park_tuning` its
    journals: the session's closing step."""
    from mahn_evo.experiment.plan import PLAN_FILE

    for exp in sorted(p for p in runs_dir.iterdir() if (p / PLAN_FILE).exists()):
        if (HERE / exp.name / PLAN_FILE).exists():
            log(f"parked {park(exp, exp.name, log=log)}")
        else:
            log(f"{exp.name}: not parked before (park it by name once, if it is to be kept)")
    fair = runs_dir / "fair"
    # a finished run kept in fair_runs/ (archive.py) is not parked again: queue.sh counts it as finished, and its
    # parked copy (a checkpoint included) would only sit in the repository
    found = lean_runs(fair)
    done = {run.name for run in found if kept(run)}
    for name in sorted(done):
        log(f"{name}: finished and kept in {FAIR_RUNS.name}/, not parked")
    if len(found) > len(done):
        log(f"parked {park_lean(fair, 'fair', log=log, skip=done)}")
    for path in park_tuning(fair, log=log):
        log(f"kept {path}")


def listing() -> list[dict]:
    """Every parked run, finished or not by its experiment's plan (mahn_evo.experiment.table.load_runs)."""
    from mahn_evo.experiment.plan import PLAN_FILE, ExperimentPlan
    from mahn_evo.experiment.table import load_runs

    out = []
    for exp in sorted(p for p in HERE.iterdir() if NAME.fullmatch(p.name) and (p / PLAN_FILE).exists()):
        for record in load_runs(ExperimentPlan.load(exp), exp):
            if record.folder.exists():
                out.append({"experiment": exp.name, "run": record.name, "generations": generations(record.folder),
                            "finished": record.finished})
    for folder in sorted(p for p in HERE.iterdir() if NAME.fullmatch(p.name) and not (p / PLAN_FILE).exists()):
        for run in lean_runs(folder):
            out.append({"lean_runs": folder.name, "run": run.name, "updates": updates(run),
                        "finished": (run / "summary.json").exists()})
    return out


def main(argv: list[str]) -> int:
    force = "--force" in argv
    argv = [a for a in argv if a != "--force"]
    try:
        if len(argv) in (2, 3) and argv[0] == "park":
            exp = Path(argv[1])
            print(park(exp, argv[2] if len(argv) == 3 else exp.resolve().name, force))
            return 0
        if len(argv) == 3 and argv[0] == "restore" and not force:
            restore(argv[1], Path(argv[2]))
            return 0
        if len(argv) in (2, 3) and argv[0] == "park-lean":
            folder = Path(argv[1])
            print(park_lean(folder, argv[2] if len(argv) == 3 else folder.resolve().name, force))
            return 0
        if len(argv) == 3 and argv[0] == "restore-lean" and not force:
            restore_lean(argv[1], Path(argv[2]))
            return 0
        if len(argv) == 2 and argv[0] == "park-all" and not force:
            park_all(Path(argv[1]))
            return 0
        if len(argv) == 3 and argv[0] == "finished" and not force:
            return 0 if finished(Path(argv[1]), float(argv[2])) else 1
        if argv == ["list"] and not force:
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
