"""`mahn-evo experiment`: the paper's whole evaluation as one resumable command.

plan (experiment.json) -> independent seeded runs (runs/<mode>_sNNN, local processes or Ray)
-> table (solved runs, generation of first solution, Fisher's exact test) -> most general solutions
(generalisation test per run) -> transfer tests (maps x protocols x noise) -> results.json, results.md, figures.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..storage.files import remove_stray_temp_files
from ..storage.folder_lock import folder_lock, lock_holder
from .backends import run_tasks
from .plan import PLAN_FILE, REPORT_OPTIONS, ExperimentPlan
from .report import write_results


def run_experiment(plan: ExperimentPlan, out: str | Path, backend: str = "local", workers: int = 2,
                   address: str | None = None, analyse: bool = True, run: bool = True,
                   log: Callable[[str], None] = print, analysis: dict[str, Any] | None = None,
                   only_seeds: list[int] | None = None) -> dict[str, Any]:
    """Run (or resume) the experiment's runs and write its report.  With run=False, report on the experiment as
    saved, whatever plan the caller passed, but for `analysis`: report options (top, general_episodes,
    transfer_episodes) that replace the saved ones, in experiment.json too.  `only_seeds` runs those of the plan's
    seeds alone (its runs split across machines, or runs lost with one redone); each is the run the whole
    experiment would make, and the report counts the runs finished in the folder."""
    out = Path(out)
    if not run:
        if not (out / PLAN_FILE).exists():
            raise ValueError(f"{str(out)!r} holds no experiment ({PLAN_FILE} missing); start it without --report-only")
        saved = ExperimentPlan.load(out)
        if analysis:
            unknown = sorted(set(analysis) - set(REPORT_OPTIONS))
            if unknown:
                raise ValueError(f"report options are {list(REPORT_OPTIONS)}, got {unknown}")
            saved = replace(saved, **analysis)
        results = write_results(saved, out, log=log, workers=workers)
        if analysis:  # only a report that was written keeps its options (a failed one leaves the plan as it was)
            with folder_lock(out, "experiment folder"):
                saved.save_or_check(out)
        return results
    with folder_lock(out, "experiment folder"):
        return _run(plan, out, backend, workers, address, analyse, log, only_seeds)


def _run(plan: ExperimentPlan, out: Path, backend: str, workers: int, address: str | None, analyse: bool,
         log: Callable[[str], None], only_seeds: list[int] | None = None) -> dict[str, Any]:
    if only_seeds is not None:
        outside = sorted(set(only_seeds) - set(plan.seeds()))
        if outside or not only_seeds:
            raise ValueError(f"--only-seeds must name seeds of the experiment ({plan.seeds()[0]}-"
                             f"{plan.seeds()[-1]}), got {sorted(only_seeds)}")
    plan.save_or_check(out)
    tasks = [(folder.name, plan.train_config(mode, seed).to_dict(), str(folder))
             for mode, seed, folder in plan.tasks(out) if only_seeds is None or seed in only_seeds]
    holders = {name: lock_holder(folder) for name, _, folder in tasks}
    busy = [f"{name} (process {pid or 'unknown'})" for name, pid in holders.items() if pid is not None]
    if busy:  # e.g. workers of a killed experiment that outlived it: two writers would corrupt the runs
        raise ValueError(f"run folder(s) of {str(out)!r} are in use by other processes: {', '.join(busy)}; stop "
                         "them first")
    remove_stray_temp_files(out)
    t0 = time.perf_counter()
    count = [0]

    def on_done(name: str, summary: dict) -> None:
        count[0] += 1
        sol = summary.get("first_solved_generation")
        log(f"[{count[0]}/{len(tasks)}] {name}: " + (f"solved at generation {sol}" if sol is not None else
            "not solved") + f", best {summary.get('best_fitness') or 0:.2f} after {summary['generations']} "
            f"generations ({summary.get('wall_seconds', 0):.0f} s)")

    which = f"seeds {sorted(set(only_seeds))} of " if only_seeds is not None else ""
    log(f"experiment {out}: {len(tasks)} runs ({which}{', '.join(plan.modes)} x {plan.runs} seeds from {plan.seed}), "
        f"backend {backend}, {workers} worker(s)")
    run_tasks(tasks, backend=backend, workers=workers, address=address, on_done=on_done)
    wall = time.perf_counter() - t0
    if not analyse:
        return {}
    return write_results(plan, out, runs_wall_seconds=wall, log=log, workers=workers if backend == "local" else 1)
