"""Keep finished budget runs of issue 12 here, without their checkpoints, and print their table rows.

Why: run folders do not survive this project's sessions; what a finished run says (its log, summary, config and
best controllers or actor) is small and is what `mahn-baselines compare --no-train --evo-runs ... --rl-runs ...`
reads.  A run that has not finished its budget is refused, so a partial run is never kept as if it had finished.

Usage: python docs/results/baselines/fair_runs/archive.py COMMIT RUN_DIR ...
(an IPOP-CMA-ES / CMA-ES run: RUN_DIR/{log.csv,summary.json,config.json,best_controllers.json}; a lean PPO run
(`mahn-baselines lean`): RUN_DIR/{config.json,summary.json,eval_log.csv,train_log.csv,best_actor.npz,best.json,
best_sampled_actor.npz,best_sampled.json};
copied to fair_runs/<name of RUN_DIR>/, and the README row of each printed; the rows go into README.md's table by
hand, before the paragraph under it)
"""
from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
FILES = ("log.csv", "summary.json", "config.json", "best_controllers.json")
LEAN_FILES = ("config.json", "summary.json", "eval_log.csv", "train_log.csv", "best_actor.npz", "best.json",
              "best_sampled_actor.npz", "best_sampled.json")


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


def _steps(n: int) -> str:
    """A budget as the commands write it: 200000000 -> 2e8 (exact only), else the number."""
    mantissa, exponent = f"{n:.0e}".split("e")
    return f"{mantissa}e{int(exponent)}" if int(float(f"{n:.0e}")) == n and n >= 1000 else str(n)


def lean_row(name: str, summary: dict, config: dict, commit: str) -> str:
    """The README row of one lean PPO run (its settings: the method's tuned ones, tune_<method>/best.json)."""
    m = config["map"]
    cmd = (f"`mahn-baselines lean --method {config['method']} --steps {_steps(int(config['steps']))} --seed "
           f"{config['seed']} --out runs/fair/{name} --resume --hyperparams "
           f"\"$(cat runs/fair/tune_{config['method']}/best.json)\"` (commit {commit})")
    first = summary.get("first_solved_steps")
    what = (f"solved first at {first:,} robot-steps" if first is not None else "not solved") + (
        f", best greedy fitness {summary['best'][f'fitness_{m}']:.2f} (at {summary['best_at_steps']:,} robot-steps), "
        f"final {summary['final'][f'fitness_{m}']:.2f}; {summary['steps']:,} robot-steps")
    sampled = summary.get("best_sampled")  # runs finished before it was summarised lack it (compare reads the log)
    if sampled:
        what += (f"; sampling policy: best mean team fitness {sampled['fitness_mean']:.2f}, solved rate "
                 f"{sampled['solved_rate']:.2f} (at {sampled['steps']:,} robot-steps)")
    again = summary.get("best_sampled_evaluation")
    if again:
        what += f", on {again['episodes']} fresh episodes " + ", ".join(
            f"{k} {v['fitness']:.2f} (solved {v['solved_rate']:.2f})" for k, v in again.items() if k != "episodes")
    return f"| [`{name}/`]({name}/) | {cmd} | {what} | {summary['cpu_seconds']:.0f} |"


def keep(run: Path, commit: str) -> str:
    """Copy one finished run here; returns its README row.  SystemExit names what is missing or unfinished."""
    if not (run / "config.json").is_file():
        sys.exit(f"{run}: not a run folder (no config.json)")
    config = json.loads((run / "config.json").read_text())
    lean = config.get("kind") == "lean_config"
    files = LEAN_FILES if lean else FILES
    missing = [f for f in files if not (run / f).is_file()]
    if missing:
        sys.exit(f"{run}: not a finished run (missing {', '.join(missing)})")
    summary = json.loads((run / "summary.json").read_text())
    if lean:
        if summary["steps"] < int(config["steps"]):
            sys.exit(f"{run}: {summary['steps']} of {int(config['steps'])} robot-steps: not finished, not kept")
    else:
        budget = int(config["generations"]) * int(config["popsize"])
        searches = summary.get("searches") or [{"popsize": config["popsize"]}]
        if summary["evaluations"] + int(searches[-1]["popsize"]) <= budget:  # the run's own rule for one more
            sys.exit(f"{run}: {summary['evaluations']} of {budget} teams evaluated and room for another "
                     f"generation: not finished, not kept")
    dest = HERE / run.name
    dest.mkdir(exist_ok=True)
    for f in files:
        shutil.copyfile(run / f, dest / f)
    return (lean_row if lean else row)(run.name, summary, config, commit)


def main() -> None:
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    for run in map(Path, sys.argv[2:]):
        print(keep(run, sys.argv[1]))


if __name__ == "__main__":
    main()
