"""HyperNEAT versus RL at matched budgets: curves, table and plot of training-map fitness and solved rate.

Budget unit: robot-steps (one robot simulated for one tick).  An RL run's budget is SB3's `num_timesteps` (every
slot is one robot); an evolution run's budget is `evaluations x max_cycles x robots` (every team evaluated is one
episode of 1364 ticks for 3 robots), read from its `log.csv` (`evaluations` is cumulative).
Both sides report the best team found so far, scored on the training map: evolution's `best_fitness` column
(its champion so far), and for RL the greedy policy of the best checkpoint so far (`eval_log.csv`).  Solved rate =
fraction of seeds whose best-so-far team solves the task by that budget.

A lean PPO run is also read as its sampling policy, the stochastic policy PPO trains (method `<method>_sampled`,
`sampled_curve`): the mean team fitness of each update's training episodes (`train_log.csv`, whole episodes of the
training map played by the policy as it was before that update; their robot-steps are part of the budget, as an
evolution run's evaluations are), best so far, and solved once at least `SAMPLED_SOLVED_RATE` of one update's
episodes solve the task.  Why: PPO's greedy argmax is not the policy it optimises, and on this task the two differ
widely (the feed-forward tuning's best trial: a sampling policy of mean team fitness 15.5 over its last updates,
its greedy policy 2.1, about the all-forward team's 2.0), so reporting only the greedy one would understate RL.
It costs nothing: those episodes are the rollouts the run trained on.

Compute-matched curves (``comparison_cpu.png``) put the same best-so-far values against the seconds each run
spent: the process CPU-seconds that lean PPO, CMA-ES and NEAT-direct runs log (``cpu_seconds``), and for
HyperNEAT runs the summed per-generation ``seconds`` of their `log.csv` (the wall time of a run that has a core
to itself, as the experiments run them: one process per run, one numba thread).  A run that logs neither has no
such curve and is left out of that plot.
"""
from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mahn_evo.storage.files import read_json_object

from ..io import read_csv, read_json, write_csv, write_json

ROBOTS = 3
TICKS = 1364


#: a budget at most this fraction beyond a run's end is read as its end.  Why: the runs of one method end within a
#: generation of their common budget (IPOP-CMA-ES: 499,300-500,000 teams), and without it the last budgets of the
#: grid would average over the runs that happened to end last (12 of 15 solved read as 14 of 15)
END_TOLERANCE = 0.01

#: a lean PPO run's sampling-policy rows (`sampled_curve`) are named after its method with this suffix
SAMPLED_SUFFIX = "_sampled"


@dataclass
class Curve:
    """One run's best-so-far fitness and solved flag against budget (robot-steps)."""

    method: str
    seed: Any
    budget: np.ndarray
    fitness: np.ndarray
    solved: np.ndarray
    source: str
    #: a run that stopped because it solved the task keeps its final values at larger budgets (its best team
    #: would still be the best); any other run is unknown (NaN) beyond the budget it was given
    holds_after_end: bool = False
    #: seconds spent by each record (aligned with `budget`), or None when the run does not log them
    cpu: np.ndarray | None = None

    def on_cpu(self) -> Curve | None:
        """The same curve with CPU-seconds as its budget (None without them): the compute-matched view.  Its run
        holds its final values after its last second: every run of a method has the same budget in robot-steps but
        spends it in different CPU-seconds, and a run that finished its budget in fewer seconds had its result by
        then (without holding, a method's mean at a late second would be over its slowest runs only)."""
        if self.cpu is None:
            return None
        order = np.argsort(self.cpu, kind="stable")
        return Curve(self.method, self.seed, self.cpu[order], np.maximum.accumulate(self.fitness[order]),
                     np.maximum.accumulate(self.solved[order]), self.source, holds_after_end=True)

    def at(self, budget: float) -> tuple[float, float]:
        """Best-so-far values at a budget (NaN before the run's first record or beyond its end; up to END_TOLERANCE
        beyond it, its end)."""
        if budget > self.budget[-1] * (1 + END_TOLERANCE):
            if self.holds_after_end:
                return float(self.fitness[-1]), float(self.solved[-1])
            return math.nan, math.nan
        i = int(np.searchsorted(self.budget, budget, side="right")) - 1
        if i < 0:
            return math.nan, math.nan
        return float(self.fitness[i]), float(self.solved[i])


def _truthy(v: str) -> bool:
    return str(v).strip().lower() in ("1", "true", "yes", "1.0")


def _best_so_far(budget: list[float], fitness: list[float], solved: list[bool],
                 cpu: list[float] | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Records sorted by budget with fitness and solved as running maxima (and the seconds in the same order)."""
    order = np.argsort(budget, kind="stable")
    b = np.asarray(budget, dtype=np.float64)[order]
    f = np.maximum.accumulate(np.asarray(fitness, dtype=np.float64)[order])
    s = np.maximum.accumulate(np.asarray(solved, dtype=np.float64)[order])
    c = None if cpu is None else np.asarray(cpu, dtype=np.float64)[order]
    return b, f, s, c


def _cpu_column(rows: Sequence[dict[str, str]], where: str) -> list[float] | None:
    """The cumulative `cpu_seconds` column, or the running sum of per-generation `seconds` (HyperNEAT's log),
    or None if the log has neither."""
    try:
        if "cpu_seconds" in rows[0]:
            return [float(r["cpu_seconds"]) for r in rows]
        if "seconds" in rows[0]:
            return np.cumsum([float(r["seconds"]) for r in rows]).tolist()
    except ValueError as e:
        raise ValueError(f"{where}: a seconds value is not a number ({e})") from None
    return None


def rl_curve(run_dir: str | Path) -> Curve:
    run_dir = Path(run_dir)
    cfg = read_json(run_dir / "config.json")
    rows = read_csv(run_dir / "eval_log.csv")
    if not rows:
        raise ValueError(f"{run_dir}/eval_log.csv has no rows")
    m = cfg["map"]
    b, f, s, c = _best_so_far([float(r["steps"]) for r in rows], [float(r[f"fitness_{m}"]) for r in rows],
                              [_truthy(r[f"solved_{m}"]) for r in rows], _cpu_column(rows, f"{run_dir}/eval_log.csv"))
    return Curve(cfg["algo"], cfg["seed"], b, f, s, str(run_dir), cpu=c)


#: a sampling policy counts as solving the task once at least this fraction of one update's training episodes solve it
SAMPLED_SOLVED_RATE = 0.5
#: the lean PPO training log's columns a sampling-policy curve reads (`baselines.lean.ppo.TRAIN_FIELDS`)
SAMPLED_COLUMNS = ("steps", "fitness_mean", "solved_rate")


def sampled_curve(run_dir: str | Path) -> Curve | None:
    """A lean PPO run's sampling policy (see the module docstring), or None for a run that has no training log of
    whole-episode rollouts (SB3 runs)."""
    run_dir = Path(run_dir)
    cfg = read_json(run_dir / "config.json")
    path = run_dir / "train_log.csv"
    if cfg.get("kind") != "lean_config" or not path.is_file():
        return None
    rows = read_csv(path)
    if not rows:
        return None
    missing = set(SAMPLED_COLUMNS) - set(rows[0])
    if missing:
        raise ValueError(f"{path} lacks column(s) {sorted(missing)}")
    try:
        steps = [float(r["steps"]) for r in rows]
        fitness = [float(r["fitness_mean"]) for r in rows]
        solved = [float(r["solved_rate"]) >= SAMPLED_SOLVED_RATE for r in rows]
    except ValueError as e:
        raise ValueError(f"{path}: a value is not a number ({e})") from None
    b, f, s, c = _best_so_far(steps, fitness, solved, _cpu_column(rows, str(path)))
    return Curve(f"{cfg['algo']}{SAMPLED_SUFFIX}", cfg["seed"], b, f, s, str(run_dir), cpu=c)


def rl_curves(run_dir: str | Path) -> list[Curve]:
    """Every curve of an RL run: its greedy policy (`rl_curve`) and, for a lean PPO run, its sampling policy."""
    sampled = sampled_curve(run_dir)
    return [rl_curve(run_dir)] + ([sampled] if sampled is not None else [])


def evo_curve(run_dir: str | Path, ticks: int = TICKS, robots: int = ROBOTS) -> Curve:
    """An `mahn-evo train` run (or a `mahn-baselines cmaes` run): `log.csv` (generation, evaluations,
    best_fitness, solved) + `summary.json` (`mode`, and `method` where it is not HyperNEAT)."""
    run_dir = Path(run_dir)
    rows = read_csv(run_dir / "log.csv")
    if not rows:
        raise ValueError(f"{run_dir}/log.csv has no rows")
    missing = {"evaluations", "best_fitness", "solved"} - set(rows[0])
    if missing:
        raise ValueError(f"{run_dir}/log.csv lacks column(s) {sorted(missing)}")
    summary_path = run_dir / "summary.json"
    summary = read_json_object(summary_path, "summary") if summary_path.exists() else {}  # names a bad file
    mode = summary.get("mode", "unknown")
    b, f, s, c = _best_so_far([float(r["evaluations"]) * ticks * robots for r in rows],
                              [float(r["best_fitness"]) for r in rows], [_truthy(r["solved"]) for r in rows],
                              _cpu_column(rows, f"{run_dir}/log.csv"))
    # HyperNEAT runs are named by their mode; other evolution runs (direct-encoding CMA-ES) name themselves
    method = summary.get("method") or f"hyperneat_{mode}"
    return Curve(method, summary.get("seed", run_dir.name), b, f, s, str(run_dir),
                 holds_after_end=bool(summary.get("solved")) and bool(s[-1]), cpu=c)


def published_curves(path: str | Path, methods: Sequence[str] | None = None) -> list[Curve]:
    """The curves of an earlier comparison (its comparison.json), optionally only `methods`: run folders do not
    outlive the machine they ran on, their comparison.json does, so a comparison can be assembled from published
    pieces.  A curve saved without `holds_after_end` holds when it ended solved (its best-so-far team stays)."""
    path = Path(path)
    data = read_json_object(path, "comparison")
    curves = data.get("curves")
    if not isinstance(curves, list):
        raise ValueError(f"{path}: no 'curves' list (is it a comparison.json written by `compare`?)")
    out = []
    for i, c in enumerate(curves):
        try:
            if methods is not None and c["method"] not in methods:
                continue
            budget, fitness = np.asarray(c["budget"], float), np.asarray(c["fitness"], float)
            solved = np.asarray(c["solved"], float)
            cpu = None if c.get("cpu_seconds") is None else np.asarray(c["cpu_seconds"], float)
        except (KeyError, TypeError, ValueError) as e:
            raise ValueError(f"{path}: curve {i} is malformed ({type(e).__name__}: {e})") from None
        lengths = {len(budget), len(fitness), len(solved)} | ({len(cpu)} if cpu is not None else set())
        if len(lengths) != 1 or not len(budget):
            raise ValueError(f"{path}: curve {i} ({c['method']}) has columns of different or zero lengths")
        out.append(Curve(str(c["method"]), c.get("seed"), budget, fitness, solved, str(c.get("source", path)),
                         holds_after_end=bool(c.get("holds_after_end", solved[-1] > 0)), cpu=cpu))
    if methods is not None and not out:
        raise ValueError(f"{path}: no curve of method(s) {sorted(methods)}; it has "
                         f"{sorted({str(c.get('method')) for c in curves if isinstance(c, dict)})}")
    return out


def budget_grid(curves: Sequence[Curve], points: int = 12) -> np.ndarray:
    """Log-spaced budgets from the smallest positive first record to the largest end, plus every run's end
    (so each method's full-budget value appears in the table and on the plot)."""
    ends = [c.budget[-1] for c in curves]
    starts = [c.budget[c.budget > 0][0] for c in curves if np.any(c.budget > 0)]
    lo = max(min(starts) if starts else 1.0, 1.0)
    hi = max(ends)
    if hi <= lo:
        return np.array([hi])
    return np.unique(np.concatenate([np.round(np.geomspace(lo, hi, points)), np.asarray(ends, dtype=float)]))


def aggregate(curves: Sequence[Curve], budgets: np.ndarray) -> list[dict[str, Any]]:
    rows = []
    for method in sorted({c.method for c in curves}):
        runs = [c for c in curves if c.method == method]
        for b in budgets:
            vals = [c.at(b) for c in runs]
            f = np.array([v[0] for v in vals if not math.isnan(v[0])])
            s = np.array([v[1] for v in vals if not math.isnan(v[1])])
            rows.append({"method": method, "budget_robot_steps": int(b), "runs": int(f.size),
                         "fitness_mean": round(float(f.mean()), 4) if f.size else "",
                         "fitness_std": round(float(f.std()), 4) if f.size else "",
                         "solved_rate": round(float(s.mean()), 4) if s.size else ""})
    return rows


#: the method the solved rates are tested against (Fisher's exact test), when it is in the comparison
REFERENCE_METHOD = "hyperneat_situational"


def final_table(curves: Sequence[Curve]) -> list[dict[str, Any]]:
    """Per method at each run's full budget: seeds, budget, fitness mean/std/max, IQM with a 95% bootstrap
    interval, solved rate, Fisher's exact p-value of the solved rate against `REFERENCE_METHOD`, and the median
    CPU-seconds a run spent (blank for a method whose runs log none, e.g. published curves): the robot-steps
    budget says what each method was given, the seconds what it cost on this machine."""
    from .stats import fisher_solved, iqm, iqm_ci

    out = []
    finals = {}
    for method in sorted({c.method for c in curves}):
        runs = [c for c in curves if c.method == method]
        finals[method] = (int(sum(bool(c.solved[-1]) for c in runs)), len(runs))
    for method in sorted({c.method for c in curves}):
        runs = [c for c in curves if c.method == method]
        f = np.array([c.fitness[-1] for c in runs])
        s = np.array([c.solved[-1] for c in runs])
        first = [c.budget[int(np.argmax(c.solved > 0))] for c in runs if np.any(c.solved > 0)]
        lo, hi = iqm_ci(f)
        ref = finals.get(REFERENCE_METHOD)
        spent = [float(c.cpu.max()) for c in runs if c.cpu is not None and c.cpu.size]  # each run's CPU-seconds
        out.append({"method": method, "runs": len(runs), "budget_robot_steps": int(max(c.budget[-1] for c in runs)),
                    "fitness_mean": round(float(f.mean()), 3), "fitness_std": round(float(f.std()), 3),
                    "fitness_max": round(float(f.max()), 3), "fitness_iqm": round(iqm(f), 3),
                    "fitness_iqm_ci95": f"{lo:.3f}-{hi:.3f}", "solved_rate": round(float(s.mean()), 3),
                    "median_budget_to_solve": int(np.median(first)) if first else "",
                    f"fisher_p_vs_{REFERENCE_METHOD}": "" if ref is None or method == REFERENCE_METHOD
                    else round(fisher_solved(*finals[method], *ref), 4),
                    "median_cpu_seconds": round(float(np.median(spent))) if spent else ""})
    return out


def markdown_table(rows: Sequence[dict[str, Any]]) -> str:
    if not rows:
        return ""
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        lines.append("| " + " | ".join(str(r[k]) for k in keys) + " |")
    return "\n".join(lines)


def method_styles(methods: Collection[str]) -> dict[str, tuple[str, str]]:
    """Each method's (colour, line style), given once for every figure of a comparison.

    Why: the compute-matched figure holds fewer methods than the robot-steps one (published curves carry no
    seconds), so colours assigned figure by figure gave one method two colours on one page. A lean PPO run's
    greedy and sampling policies are one run read two ways: they share a colour, the greedy one dashed."""
    bases = sorted({m.removesuffix(SAMPLED_SUFFIX) for m in methods})
    palette = [f"C{i % 10}" for i in range(len(bases))]
    colour = dict(zip(bases, palette))
    return {m: (colour[m.removesuffix(SAMPLED_SUFFIX)],
                "-" if m.endswith(SAMPLED_SUFFIX) or f"{m}{SAMPLED_SUFFIX}" not in methods else "--")
            for m in methods}


def plot(curves: Sequence[Curve], budgets: np.ndarray, path: Path,
         xlabel: str = "budget (robot-steps = teams x 1364 ticks x 3 robots)",
         styles: dict[str, tuple[str, str]] | None = None) -> None:
    """Mean best-so-far fitness (band: one standard deviation) and solved rate against `budgets`; `styles` (from
    `method_styles`, default: the methods of `curves`) keeps a method's colour the same across figures."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_f, ax_s) = plt.subplots(1, 2, figsize=(11, 4.2))
    styles = styles or method_styles({c.method for c in curves})
    for method in sorted({c.method for c in curves}):
        colour, ls = styles[method]
        runs = [c for c in curves if c.method == method]
        end = max(c.budget[-1] for c in runs)  # a line ends where the method's runs end (held runs run on)
        agg = [r for r in aggregate(runs, budgets)
               if r["runs"] and r["budget_robot_steps"] <= end * (1 + END_TOLERANCE)]
        x = np.array([r["budget_robot_steps"] for r in agg], dtype=float)
        mean = np.array([r["fitness_mean"] for r in agg], dtype=float)
        std = np.array([r["fitness_std"] for r in agg], dtype=float)
        ax_f.plot(x, mean, marker="o", ms=3, label=method, color=colour, ls=ls)
        ax_f.fill_between(x, mean - std, mean + std, alpha=0.2, color=colour)
        ax_s.plot(x, [r["solved_rate"] for r in agg], marker="o", ms=3, label=method, color=colour, ls=ls)
    for ax, ylabel in ((ax_f, "best team fitness so far (training map)"), (ax_s, "solved rate (fraction of seeds)")):
        ax.set_xscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    ax_f.axhline(100, color="grey", ls=":", lw=1)
    ax_s.set_ylim(-0.05, 1.05)
    ax_s.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)


def compare(rl_runs: Sequence[str | Path], evo_runs: Sequence[str | Path], out: str | Path,
            points: int = 12, published: Sequence[Curve] = ()) -> dict[str, Any]:
    """Read runs (and take `published` curves as they are), write comparison.{csv,md,json,png} into `out`; returns
    the JSON payload."""
    curves = [c for d in rl_runs for c in rl_curves(d)] + [evo_curve(d) for d in evo_runs] + list(published)
    if not curves:
        raise ValueError("nothing to compare: give RL run directories and/or --evo-runs")
    out = Path(out)
    budgets = budget_grid(curves, points)
    rows = aggregate(curves, budgets)
    table = final_table(curves)
    write_csv(out / "comparison.csv", list(rows[0]), rows)
    md = ["# HyperNEAT vs RL baselines (training map, best-so-far team)", "",
          "Budget in robot-steps; evolution: teams evaluated x 1364 ticks x 3 robots.", "",
          "## At full budget", "", markdown_table(table), "", "## Versus budget", "", markdown_table(rows), ""]
    from ..io import _atomic_write_text

    _atomic_write_text(out / "comparison.md", "\n".join(md))
    payload = {"budgets": budgets.tolist(), "table": table, "curves": [
        {"method": c.method, "seed": c.seed, "source": c.source, "budget": c.budget.tolist(),
         "fitness": c.fitness.tolist(), "solved": c.solved.astype(bool).tolist(),
         "cpu_seconds": None if c.cpu is None else c.cpu.tolist(), "holds_after_end": c.holds_after_end}
        for c in curves]}
    write_json(out / "comparison.json", payload)
    styles = method_styles({c.method for c in curves})
    plot(curves, budgets, out / "comparison.png", styles=styles)
    on_cpu = [v for v in (c.on_cpu() for c in curves) if v is not None]
    if on_cpu:  # compute-matched: the same best-so-far values against the seconds each run spent
        xlabel = "CPU-seconds per run"
        if any(c.method.startswith("hyperneat") for c in on_cpu):
            xlabel += " (HyperNEAT: seconds of a single-threaded run)"
        plot(on_cpu, budget_grid(on_cpu, points), out / "comparison_cpu.png", xlabel=xlabel, styles=styles)
    return payload


def train_missing(algos: Sequence[str], seeds: Sequence[int], steps: int, runs_dir: str | Path,
                  overrides: dict[str, Any] | None = None, log=print) -> list[Path]:
    """Train every (algo, seed) run that has no `summary.json` yet (so an interrupted comparison resumes)."""
    from ..sb3.train import TrainConfig, default_out, run_exists, train

    dirs = []
    for algo in algos:
        for seed in seeds:
            d = default_out(algo, seed, runs_dir)
            dirs.append(d)
            if run_exists(d):
                log(f"[skip] {d} already trained")
                continue
            log(f"[train] {algo} seed {seed}: {steps} robot-steps -> {d}")
            s = train(TrainConfig(algo=algo, steps=steps, seed=seed, **(overrides or {})), d)
            log(f"        best {s['best']}  ({s['wall_time']} s, {s['robot_steps_per_second']} robot-steps/s)")
    return dirs


def evo_budget(evo_runs: Sequence[str | Path]) -> int | None:
    """The largest evolution budget among the runs (robot-steps), to match RL's training budget to it."""
    ends = [int(evo_curve(d).budget[-1]) for d in evo_runs]
    return max(ends) if ends else None
