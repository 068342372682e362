"""`mahn-baselines`: train, tune, evaluate and compare the baselines (a thin layer over `sb3/`, `lean/`, `direct/`,
`evaluate.py` and `comparison/`)."""
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from mahn_envs.core.params import ORIGINAL_MAX_TICKS, ORIGINAL_SIGNAL_TICK

from .lean.config import METHODS as LEAN_METHODS
from .sb3.algos import ALGO_NAMES
from .sb3.train import EVAL_MAPS


def _json_dict(text: str) -> dict:
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise argparse.ArgumentTypeError(f"not valid JSON: {exc}") from exc
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError("must be a JSON object, e.g. '{\"learning_rate\": 1e-4}'")
    return value


def _direct_run_options(p: argparse.ArgumentParser, folder: str, unit: str) -> None:
    """The run options the direct-encoding controls (cmaes, neat-direct) share: seed, folder, resume, episodes,
    checkpoints and the task's map and timing."""
    p.add_argument("--seed", type=int, default=0, help="the run's seed (default %(default)s)")
    p.add_argument("--out", type=Path, required=True, help=f"run folder ({folder})")
    p.add_argument("--resume", action="store_true", help="continue the run in --out if there is one")
    p.add_argument("--episodes", type=int, default=1, help=f"episodes per {unit}")
    p.add_argument("--checkpoint-every", type=int, default=10, help="generations between checkpoints")
    p.add_argument("--map", default="plus", help="training map (default %(default)s)")
    p.add_argument("--max-cycles", type=int, default=ORIGINAL_MAX_TICKS,
                   help="episode length in ticks (default: the paper's)")
    p.add_argument("--signal-tick", type=int, default=ORIGINAL_SIGNAL_TICK, help="tick of the come-home signal")


def _add_task_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--n-episodes", type=int, default=16, help="lock-stepped episodes per batch (slots = x3)")
    p.add_argument("--max-cycles", type=int, default=1364, help="episode length in ticks (default: the paper's)")
    p.add_argument("--signal-tick", type=int, default=690, help="tick of the come-home signal")
    p.add_argument("--reward-scale", type=float, default=0.1, help="training reward = team reward x this")
    p.add_argument("--eval-every", type=int, default=0, help="robot-steps between evaluations (0: steps/20)")
    p.add_argument("--threads", type=int, default=1, help="torch threads")
    p.add_argument("--hyperparams", type=_json_dict, default={}, help="JSON overrides of the SB3 hyper-parameters")


def _task_overrides(a: argparse.Namespace) -> dict:
    return {"n_episodes": a.n_episodes, "max_cycles": a.max_cycles, "signal_tick": a.signal_tick,
            "reward_scale": a.reward_scale, "eval_every": a.eval_every, "torch_threads": a.threads,
            "hyperparams": a.hyperparams}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="mahn-baselines", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    t = sub.add_parser("train", help="train one run (PPO, RecurrentPPO or DQN, parameter sharing)")
    t.add_argument("--algo", choices=ALGO_NAMES, required=True, help="stable-baselines3 algorithm")
    t.add_argument("--steps", type=int, required=True, help="budget in robot-steps (SB3 timesteps)")
    t.add_argument("--seed", type=int, default=0, help="the run's seed (default %(default)s)")
    t.add_argument("--out", type=Path, required=True, help="run folder (models, log, summary)")
    t.add_argument("--map", default="plus", help="training map")
    t.add_argument("--progress", action="store_true", help="show a progress bar")
    _add_task_args(t)

    e = sub.add_parser("eval", help="score a trained run (team fitness, solved) on maps x protocols")
    e.add_argument("run", type=Path, help="a run folder of `train` or `lean`")
    e.add_argument("--maps", nargs="+", default=list(EVAL_MAPS), help="maps to score on (default: %(default)s)")
    e.add_argument("--protocols", nargs="+", default=["training", "sequential"],
                   help="training (signal at tick 690) and/or sequential (needs mahn_evo.evaluation.protocols)")
    e.add_argument("--episodes", type=int, default=1, help="episodes per map and protocol (default %(default)s)")
    e.add_argument("--seed", type=int, default=0, help="seed of the evaluation episodes (default %(default)s)")
    e.add_argument("--model", choices=("best", "final", "best_sampled"), default="best",
                   help="the best checkpoint seen during training or the last one, or (lean runs) the actor whose "
                        "sampled rollout scored best: use it with --stochastic (default %(default)s)")
    e.add_argument("--stochastic", action="store_true", help="sample actions instead of the greedy policy")
    e.add_argument("--json", action="store_true", help="print the results as JSON")

    c = sub.add_parser("compare", help="several seeds per method at matched budgets, table + plot")
    c.add_argument("--runs-dir", type=Path, default=Path("runs/baselines"), help="where RL runs live / go")
    c.add_argument("--algos", nargs="*", default=list(ALGO_NAMES), choices=ALGO_NAMES,
                   help="stable-baselines3 algorithms compared (default: all)")
    c.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2], help="seeds per algorithm (default 0 1 2)")
    c.add_argument("--steps", type=int, default=None,
                   help="RL budget in robot-steps (default: the largest evolution budget among --evo-runs)")
    c.add_argument("--no-train", action="store_true", help="only compare runs that already exist")
    c.add_argument("--evo-runs", nargs="*", type=Path, default=[],
                   help="mahn-evo train (or mahn-baselines cmaes / neat-direct) output directories")
    c.add_argument("--rl-runs", nargs="*", type=Path, default=[],
                   help="more finished RL run directories to include as they are (e.g. mahn-baselines lean runs)")
    c.add_argument("--published", nargs="*", type=Path, default=[], metavar="COMPARISON_JSON",
                   help="earlier comparisons (their comparison.json) whose curves join this one as they are: run "
                        "folders do not outlive their machine, published curves do")
    c.add_argument("--published-methods", nargs="*", default=None, metavar="METHOD",
                   help="take only these methods' curves from --published (default: all)")
    c.add_argument("--out", type=Path, default=Path("docs/results/baselines"),
                   help="folder of the comparison files (default %(default)s)")
    c.add_argument("--points", type=int, default=12, help="budget points in the table")
    _add_task_args(c)

    lp = sub.add_parser("lean", help="train a lean PPO run: ippo_gru, mappo_gru or ppo_ff (torch; resumable)")
    lp.add_argument("--method", choices=LEAN_METHODS, required=True,
                    help="ippo_gru / mappo_gru (recurrent; decentralised / centralised critic) or ppo_ff "
                         "(frame-stacked)")
    lp.add_argument("--steps", type=_count, required=True, help="budget in robot-steps (e.g. 1e8)")
    lp.add_argument("--seed", type=int, default=0, help="the run's seed (default %(default)s)")
    lp.add_argument("--out", type=Path, required=True, help="run folder (checkpoints, log, summary)")
    lp.add_argument("--resume", action="store_true",
                    help="continue the run in --out if there is one (else start it): one command to rerun")
    _add_lean_task_args(lp)
    lp.add_argument("--hyperparams", type=_json_dict, default={},
                    help="JSON overrides of the settings in baselines/lean/config.py (e.g. a tune best.json)")

    cm = sub.add_parser("cmaes", help="direct-encoding control: CMA-ES on the substrate networks (resumable)")
    cm.add_argument("--mode", choices=("situational", "standard"), default="situational",
                    help="policy geometry of the evolved networks (default %(default)s)")
    cm.add_argument("--generations", type=int, required=True,
                    help="CMA-ES generations to run (with restarts: the budget is this many of the first search's)")
    cm.add_argument("--popsize", type=int, default=100, help="candidates per generation (default %(default)s)")
    cm.add_argument("--sigma0", type=float, default=1.0, help="initial step size (default %(default)s)")
    cm.add_argument("--restart-patience", type=int, default=0, metavar="P",
                    help="IPOP-CMA-ES: when a search's best has not risen for P generations, restart with twice the "
                         "population until the budget (--generations x --popsize candidates) is spent (default 0: "
                         "one search)")
    _direct_run_options(cm, folder="history, log, summary", unit="candidate")

    nd = sub.add_parser("neat-direct", help="direct-encoding control: mahn's NEAT evolving the substrate networks "
                        "(not CPPNs; resumable)")
    nd.add_argument("--mode", choices=("situational", "standard"), default="situational",
                    help="policy geometry of the evolved networks (default %(default)s)")
    nd.add_argument("--generations", type=int, required=True, help="NEAT generations to run")
    nd.add_argument("--popsize", type=int, default=500, help="population size (default %(default)s, NEAT's)")
    nd.add_argument("--start", choices=("full", "feedforward"), default="full",
                    help="initial genomes: every substrate connection (full), or all but the recurrent hidden "
                         "links, which add-connection grows (feedforward); default %(default)s")
    _direct_run_options(nd, folder="checkpoint, log, summary", unit="team")
    nd.add_argument("--neat", type=_json_dict, default={},
                    help="JSON overrides of NeatSettings fields (mahn_evo/neat/settings.py), e.g. "
                         "'{\"weight_coefficient\": 0.01}'")

    tu = sub.add_parser("tune", help="optuna search of a lean PPO method's hyper-parameters (resumable)")
    tu.add_argument("--method", choices=LEAN_METHODS, required=True, help="the lean PPO method to tune")
    tu.add_argument("--trials", type=int, default=25, help="finished trials to reach")
    tu.add_argument("--steps", type=_count, default=20_000_000, help="robot-steps per trial")
    tu.add_argument("--seed", type=int, default=0, help="seed of the sampler")
    tu.add_argument("--tuning-seed", type=int, default=100, help="training seed of every trial")
    tu.add_argument("--out", type=Path, required=True, help="study folder (trials, study file, best.json)")
    tu.add_argument("--table", action="store_true",
                    help="print every finished trial of the study in --out as a markdown table, and run nothing")
    _add_lean_task_args(tu)
    return parser


def _count(text: str) -> int:
    """Budgets as integers, also written like 2e7."""
    try:
        value = float(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from exc
    if not value.is_integer() or value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive whole number, got {text!r}")
    return int(value)


def _add_lean_task_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--map", default="plus", help="training map")
    p.add_argument("--max-cycles", type=int, default=1364, help="episode length in ticks (default: the paper's)")
    p.add_argument("--signal-tick", type=int, default=690, help="tick of the come-home signal")
    p.add_argument("--threads", type=int, default=1, help="torch threads")


def _lean_task(a: argparse.Namespace) -> dict:
    return {"map": a.map, "max_cycles": a.max_cycles, "signal_tick": a.signal_tick, "torch_threads": a.threads}


def main(argv: Sequence[str] | None = None) -> int:
    a = build_parser().parse_args(argv)
    try:
        if a.command == "train":
            from .sb3.train import TrainConfig, train

            cfg = TrainConfig(algo=a.algo, steps=a.steps, seed=a.seed, map=a.map, **_task_overrides(a))
            summary = train(cfg, a.out, progress=a.progress)
            print(json.dumps(summary, indent=2))
        elif a.command == "eval":
            from .evaluate import evaluate_run, format_results

            res = evaluate_run(a.run, maps=a.maps, protocols=a.protocols, episodes=a.episodes, seed=a.seed,
                               which=a.model, stochastic=a.stochastic)
            print(json.dumps(res, indent=2) if a.json else format_results(res))
        elif a.command == "lean":
            from .lean.config import LeanConfig
            from .lean.ppo import train as lean_train

            lean_cfg = LeanConfig(method=a.method, steps=a.steps, seed=a.seed, **_lean_task(a)).with_overrides(
                a.hyperparams)
            summary = lean_train(lean_cfg, a.out, resume=a.resume,
                                 on_update=lambda r: print(f"update {r['update']}  {r['steps']} robot-steps  "
                                                           f"fitness {r['fitness_mean']:.3f} (max "
                                                           f"{r['fitness_max']:.3f})  "
                                                           f"{r['robot_steps_per_second']:.0f}/s", flush=True))
            print(json.dumps(summary, indent=2))
        elif a.command == "cmaes":
            from .direct.cmaes import CMAConfig
            from .direct.cmaes import train as cma_train

            cma_cfg = CMAConfig(mode=a.mode, generations=a.generations, popsize=a.popsize, sigma0=a.sigma0,
                                seed=a.seed, map=a.map, episodes=a.episodes, max_cycles=a.max_cycles,
                                signal_tick=a.signal_tick, restart_patience=a.restart_patience)
            summary = cma_train(cma_cfg, a.out, resume=a.resume, checkpoint_every=a.checkpoint_every,
                                on_generation=lambda r: print(f"generation {r[0]}  best {r[2]:.3f}  best ever "
                                                              f"{r[4]:.3f}  sigma {r[7]:.3f}", flush=True))
            print(json.dumps(summary, indent=2))
        elif a.command == "neat-direct":
            from .direct.neat import NeatDirectConfig
            from .direct.neat import train as neat_train

            nd_cfg = NeatDirectConfig(mode=a.mode, generations=a.generations, popsize=a.popsize, seed=a.seed,
                                      start=a.start, map=a.map, episodes=a.episodes, max_cycles=a.max_cycles,
                                      signal_tick=a.signal_tick, neat=a.neat)
            summary = neat_train(nd_cfg, a.out, resume=a.resume, checkpoint_every=a.checkpoint_every,
                                 on_generation=lambda r: print(f"generation {r[0]}  best {r[2]:.3f}  best ever "
                                                               f"{r[4]:.3f}  species {r[7]}", flush=True))
            print(json.dumps(summary, indent=2))
        elif a.command == "tune":
            from .lean.tune import trials_table, tune

            if a.table:
                print(trials_table(a.out, a.method))
                return 0
            cost = tune(a.method, a.out, trials=a.trials, steps=a.steps, seed=a.seed, tuning_seed=a.tuning_seed,
                        base=_lean_task(a))
            print(json.dumps(cost, indent=2))
        else:
            from .comparison.compare import compare, evo_budget, train_missing
            from .sb3.train import default_out, run_exists

            if a.no_train:
                rl = [default_out(al, s, a.runs_dir) for al in a.algos for s in a.seeds]
                rl = [d for d in rl if run_exists(d)]
            else:
                steps = a.steps if a.steps is not None else evo_budget(a.evo_runs)
                if steps is None:
                    raise ValueError("give --steps (or --evo-runs to match their budget)")
                rl = train_missing(a.algos, a.seeds, steps, a.runs_dir, _task_overrides(a))
            from .comparison.compare import published_curves

            earlier = [c for f in a.published for c in published_curves(f, a.published_methods)]
            payload = compare(list(rl) + list(a.rl_runs), a.evo_runs, a.out, points=a.points, published=earlier)
            from .comparison.compare import markdown_table

            print(markdown_table(payload["table"]))
            print(f"written: {a.out}/comparison.{{csv,md,json,png}}")
    except (ValueError, FileNotFoundError, NotImplementedError) as exc:
        print(f"mahn-baselines: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
