"""Budgeted hyper-parameter search for the lean PPO methods with optuna (TPE sampler, median pruner).

Budget (the issue's): about 25 trials per method at 2e7 robot-steps each, i.e. 5e8 robot-steps of tuning per
method, reported with the result (`tuning_cost.json`).  All trials train on one tuning seed (100 by default)
so that configurations are compared on the same episodes; the final runs use fresh seeds (0-4).

Objective: the mean team fitness of the sampling policy over the last 10% of a trial's updates (whole
episodes of the training map): steadier than the best greedy checkpoint, which a lucky update can set.  (The
rollout of update k is played by the policy after k - 1 updates, so a 1-update smoke trial scores the
untrained policy; at 2e7 robot-steps the last 10% are 15 updates of the trained one.)
Intermediate values (the same mean over the updates so far) feed the median pruner, which stops a trial that
is below the median of earlier trials at the same update after the first 30% of its budget.

Folder:
  study.jsonl        optuna's journal (plain JSON lines): every trial, its parameters, values and state
  trials/<key>/      one lean PPO run per parameter set (key = a digest of the settings), resumable
  tuning_cost.json   trials, robot-steps, wall and CPU seconds spent; best value and settings so far
  best.json          the best settings, as `--hyperparams` for `mahn-baselines lean`
`trials_table` (`mahn-baselines tune --method M --out DIR --table`) prints every finished trial from the journal alone.

Resumable and deterministic: the sampler for trial k is seeded with (seed, k) and sees the same finished
trials, so an interrupted study continues with the same suggestions; a trial cut off mid-run is marked failed
and its settings are asked again first, so its run folder (same key) is resumed, not restarted.
"""
from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mahn_evo.storage.files import atomic_write_json

from ..io import read_csv
from .config import METHODS, RECURRENT_METHODS, LeanConfig

DEFAULT_TRIALS = 25
DEFAULT_STEPS = 20_000_000
TUNING_SEED = 100
STUDY_FILE = "study.jsonl"


def suggest(trial: Any, method: str) -> dict[str, Any]:
    """The search space (ranges around the documented defaults of `config.py`)."""
    p: dict[str, Any] = {
        "lr": trial.suggest_float("lr", 1e-4, 3e-3, log=True),
        "gamma": trial.suggest_categorical("gamma", [0.999, 0.9995, 1.0]),
        "gae_lambda": trial.suggest_float("gae_lambda", 0.95, 1.0),
        "ent_coef": trial.suggest_float("ent_coef", 1e-4, 3e-2, log=True),
        "epochs": trial.suggest_int("epochs", 2, 8),
        "minibatches": trial.suggest_categorical("minibatches", [1, 2, 4]),
        "clip": trial.suggest_float("clip", 0.1, 0.3),
        "hidden": trial.suggest_categorical("hidden", [32, 64, 128]),
        "n_episodes": trial.suggest_categorical("n_episodes", [16, 32, 64]),
        "reward_scale": trial.suggest_categorical("reward_scale", [0.03, 0.1, 0.3]),
    }
    if method in RECURRENT_METHODS:
        p["bptt"] = trial.suggest_categorical("bptt", [341, 682, 1364])
    else:
        p["frame_stack"] = trial.suggest_categorical("frame_stack", [1, 2, 4, 8])
    return p


def _journal(path: Path) -> Any:
    """optuna's storage over a study's journal file (plain JSON lines): one way to open it, for the search and
    for `trials_table`."""
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    return JournalStorage(JournalFileBackend(str(path)))


def study_name(method: str) -> str:
    """The study's name in its journal (one method per study folder)."""
    return f"lean_{method}"


def settings_key(settings: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:12]


def objective_value(train_rows: list[dict[str, Any]]) -> float:
    """Mean training-episode team fitness over the last 10% of the updates (at least one)."""
    if not train_rows:
        raise ValueError("no training updates to score")
    tail = train_rows[-max(1, len(train_rows) // 10):]
    return float(sum(float(r["fitness_mean"]) for r in tail) / len(tail))


def tune(method: str, out: str | Path, trials: int = DEFAULT_TRIALS, steps: int = DEFAULT_STEPS,
         seed: int = 0, tuning_seed: int = TUNING_SEED, base: dict[str, Any] | None = None,
         log: Callable[[str], None] = print) -> dict[str, Any]:
    """Run (or continue) the search until `trials` trials have finished (completed or pruned)."""
    import optuna
    from optuna.trial import TrialState

    from .ppo import LeanPPO

    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if trials < 1 or steps < 1:
        raise ValueError(f"trials and steps must be positive, got {trials} and {steps}")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    storage = _journal(out / STUDY_FILE)
    name = study_name(method)
    if name in optuna.get_all_study_names(storage):  # loading writes nothing: a finished study's file stays as kept
        study = optuna.load_study(study_name=name, storage=storage)
    else:
        study = optuna.create_study(study_name=name, storage=storage, direction="maximize")
    for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):  # cut off by an interruption
        study.tell(t.number, state=TrialState.FAIL)
        study.enqueue_trial(t.params)
        log(f"[tune] trial {t.number} was interrupted: its settings run again (its folder resumes)")
    base = dict(base or {})
    while True:
        finished = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.PRUNED))
        if len(finished) >= trials:
            break
        sampler = optuna.samplers.TPESampler(seed=seed * 100_003 + len(finished))
        pruner = optuna.pruners.MedianPruner(n_startup_trials=5, n_warmup_steps=1)
        study = optuna.load_study(study_name=name, storage=storage, sampler=sampler, pruner=pruner)
        trial = study.ask()
        settings = {**base, **suggest(trial, method)}
        cfg = LeanConfig(method=method, steps=steps, seed=tuning_seed, **settings)
        run_dir = out / "trials" / settings_key({**settings, "method": method, "seed": tuning_seed,
                                                  "steps": steps})
        trial.set_user_attr("run_dir", str(run_dir))
        resume = (run_dir / "checkpoint.json").exists()
        run = LeanPPO(cfg, run_dir, resume=resume)
        warmup = max(1, math.ceil(0.3 * steps / run.steps_per_update))

        def report(row: dict[str, Any], run: LeanPPO = run, trial: Any = trial, warmup: int = warmup) -> None:
            value = objective_value(run.train_rows)
            trial.report(value, row["update"])
            if row["update"] >= warmup and trial.should_prune():
                raise optuna.TrialPruned()

        try:
            run.run(report)
            value = objective_value(run.train_rows)
            _record_cost(trial, run.train_rows)
            study.tell(trial, value)
            log(f"[tune] trial {trial.number}: {value:.4f}  {settings}")
        except optuna.TrialPruned:
            run.finish()
            _record_cost(trial, run.train_rows)
            study.tell(trial, state=TrialState.PRUNED)
            log(f"[tune] trial {trial.number} pruned at update {run.update}")
        _write_cost(study, out, method, steps)
    return _write_cost(study, out, method, steps)


#: the trial's cost as user attributes of the journal, so study.jsonl alone carries the search and its cost
COST_FIELDS = ("steps", "wall_time", "cpu_seconds")


def _record_cost(trial: Any, train_rows: list[dict[str, Any]]) -> None:
    """Store the trial's robot-steps, wall and CPU seconds (its train log's last row) in the journal: the study
    file is what is kept between sessions (trial folders hold checkpoints and are not), and the tuning cost must
    survive with it."""
    if train_rows:
        for field in COST_FIELDS:
            trial.set_user_attr(field, float(train_rows[-1][field]))


def _trial_cost(attrs: dict[str, Any]) -> dict[str, Any] | None:
    """A finished trial's cost: from the journal (`_record_cost`), else (studies from before it) the last row of
    its folder's train log, if the folder is still there; None if neither is."""
    if all(field in attrs for field in COST_FIELDS):
        return {field: attrs[field] for field in COST_FIELDS}
    run_dir = attrs.get("run_dir")
    if run_dir and (Path(run_dir) / "train_log.csv").exists():
        rows = read_csv(Path(run_dir) / "train_log.csv")
        if rows:
            return rows[-1]
    return None


def _write_cost(study: Any, out: Path, method: str, steps: int) -> dict[str, Any]:
    from optuna.trial import TrialState

    robot_steps, wall, cpu = 0, 0.0, 0.0
    for t in study.get_trials(deepcopy=False):
        if t.state not in (TrialState.COMPLETE, TrialState.PRUNED):
            continue
        last = _trial_cost(t.user_attrs)
        if last is not None:
            robot_steps += int(last["steps"])
            wall += float(last["wall_time"])
            cpu += float(last["cpu_seconds"])
    done = [t for t in study.get_trials(deepcopy=False) if t.state == TrialState.COMPLETE]
    best = max(done, key=lambda t: t.value) if done else None
    cost = {"method": method, "steps_per_trial": steps,
            "trials_completed": len(done),
            "trials_pruned": len(study.get_trials(deepcopy=False, states=(TrialState.PRUNED,))),
            "robot_steps": robot_steps, "wall_seconds": round(wall, 1), "cpu_seconds": round(cpu, 1),
            "best_value": best.value if best else None, "best_trial": best.number if best else None,
            "best_settings": best.params if best else None}
    atomic_write_json(out / "tuning_cost.json", cost)
    if best is not None:
        atomic_write_json(out / "best.json", best.params)
    return cost


#: the settings `trials_table` shows, in this order (the search space of `suggest`; a method has some of them)
TABLE_SETTINGS = ("lr", "gamma", "gae_lambda", "ent_coef", "epochs", "minibatches", "clip", "hidden", "n_episodes",
                  "reward_scale", "bptt", "frame_stack")


def _format_setting(value: Any) -> str:
    if isinstance(value, float) and not value.is_integer():
        return f"{value:.3g}" if abs(value) < 0.01 else f"{value:.4g}"
    return str(int(value)) if isinstance(value, float) else str(value)


def trials_table(out: str | Path, method: str) -> str:
    """Every finished trial of the study in `out` (study.jsonl alone) as a markdown table: its state, objective
    (a pruned trial's: the last value it reported), robot-steps, CPU-seconds and settings; the trials cut off by an
    interruption are not rows (each ran again as a later trial, resuming its folder) but are counted below.  Why:
    the search must be documented trial by trial, not only by its winner (tuning_cost.json)."""
    import optuna
    from optuna.trial import TrialState

    path = Path(out) / STUDY_FILE
    if not path.is_file():
        raise FileNotFoundError(f"no tuning journal {str(path)!r}")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.load_study(study_name=study_name(method), storage=_journal(path))
    trials = study.get_trials(deepcopy=False)
    shown = [k for k in TABLE_SETTINGS if any(k in t.params for t in trials)]
    head = ["trial", "state", "objective", "robot-steps", "CPU-s"] + shown
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    done = [t for t in trials if t.state == TrialState.COMPLETE and t.value is not None]
    best = max(done, key=lambda t: float(t.value or 0.0), default=None)
    for t in trials:
        if t.state not in (TrialState.COMPLETE, TrialState.PRUNED):
            continue
        value = t.value if t.state == TrialState.COMPLETE else (
            t.intermediate_values[max(t.intermediate_values)] if t.intermediate_values else None)
        cost = _trial_cost(t.user_attrs)
        cells = [str(t.number), "completed" if t.state == TrialState.COMPLETE else "pruned",
                 "" if value is None else (f"**{value:.2f}**" if t is best else f"{value:.2f}"),
                 "" if cost is None else f"{float(cost['steps']) / 1e6:.1f} M",
                 "" if cost is None else f"{float(cost['cpu_seconds']):.0f}"]
        cells += [_format_setting(t.params[k]) if k in t.params else "" for k in shown]
        lines.append("| " + " | ".join(cells) + " |")
    cut = sum(t.state == TrialState.FAIL for t in trials)
    running = sum(t.state == TrialState.RUNNING for t in trials)
    lines.append("")
    lines.append(f"{len(lines) - 3} finished trials; {cut} cut off by an interruption and run again"
                 + (f"; {running} running or cut off now" if running else ""))
    return "\n".join(lines)
