"""`mahn-evo`: train, evaluate and deploy multiagent HyperNEAT teams.  A thin layer over the Python API."""
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mahn_envs.core.controller import DECISIONS
from mahn_envs.maps.variants import BRANCH_SIDES

from .cppn import CPPN_ACTIVATIONS
from .evaluation.task_setup import NOISE_PRESETS, TEST_NOISES
from .hyperneat.evaluation_settings import AGGREGATES, NOISE_DRAWS
from .hyperneat.substrate import MODES, SYMMETRIES
from .training.config import INITS, REFLEX_ARC_FROM, ROBUST_FROM, EvolutionConfig, load_config_file
from .training.lifetime import FITNESS_MEMORY
from .training.presets import PRESETS, apply_preset

if TYPE_CHECKING:  # the experiment package loads only when an experiment runs
    from .experiment.plan import ExperimentPlan


def _fidelity_and_robustness_options(p: argparse.ArgumentParser) -> None:
    """Options shared by `train` and `experiment` (all default to None: the preset or the defaults decide)."""
    p.add_argument("--preset", choices=sorted(PRESETS),
                   help="a named configuration: iros2011-code (the original code's behaviour), iros2011-multistep (the "
                        "code with its MultipleSteps CPPN activation), iros2011-paper (the paper's text where it "
                        "differs), hardened (iros2011-multistep, then hardened under noise from 50 generations "
                        "after the first solution: for teams that go to robots) or best-restarts (iros2011-multistep "
                        "with --symmetry best --restart-every 150: the published experiment's configuration, 15/15 "
                        "situational runs solved) or hardened-sequential (best-restarts with a one-sided start, then "
                        "hardened with noisy training and sequential-protocol episodes on plus and its variants: "
                        "run it with --stop-when-solved --after-solved 150); flags and --config override it")
    p.add_argument("--cppn-activation", choices=CPPN_ACTIVATIONS,
                   help="recursive (default: the original's one depth-first pass, recurrent CPPN links add 0) or "
                        "relax (its MultipleSteps relaxation: modules and recurrent links live)")
    p.add_argument("--decision", choices=DECISIONS,
                   help="how outputs become actions: output (default: the original's winner-take-all on the output "
                        "sigmoids, which float32 saturates into exact ties) or net_input (on their net inputs)")
    p.add_argument("--symmetry", choices=SYMMETRIES,
                   help="none (default: each robot painted at its own z, as the paper), mirror (the robot at -z "
                        "gets the exact mirror image of the brains painted at +z: bilateral symmetry by construction) "
                        "or best (each team scored as painted and in both mirror readings; the best counts)")
    p.add_argument("--noise", choices=sorted(NOISE_PRESETS),
                   help="task noise during training (default none); with --episodes K > 1 teams are scored on K "
                        "noisy episodes")
    p.add_argument("--noise-draws", choices=NOISE_DRAWS,
                   help="fixed (default: the same K episodes every generation) or per_generation (new episodes "
                        "each generation, the same for every team of a generation)")
    p.add_argument("--aggregate", choices=AGGREGATES,
                   help="team fitness from its K episodes: mean (default), min or quantile (see --quantile)")
    p.add_argument("--quantile", type=float, help="the quantile of --aggregate quantile (default 0.25)")
    p.add_argument("--noise-free-episode", action="store_true", default=None,
                   help="with --noise: also score every team on one noise-free episode, aggregated with the noisy "
                        "ones (a team must work with and without noise)")
    p.add_argument("--map-spread", type=float, metavar="S",
                   help="map plus only: play each keyed (noisy) episode on a plus variant whose left, top and right "
                        "arms are the plus map's times factors drawn from [1-S, 1+S] per episode (default 0: the "
                        "map itself); the noise-free episode stays on the plus map")
    p.add_argument("--map-branch", type=float, metavar="B",
                   help="map plus only: the keyed (noisy) episodes' plus variants also have their left and right "
                        "arms leaving the top arm at offsets drawn from [0, B] cm above the crossing (default 0: at "
                        "the crossing), so a turn cannot rest on both sides of the crossing opening at once")
    p.add_argument("--branch-sides", choices=BRANCH_SIDES,
                   help="with --map-branch: both (default: each side arm's offset from [0, B]), one (a random "
                        "side at the crossing, the other from [corridor width, B], so the two openings never "
                        "overlap and a turn cannot wait for both) or one_short (as one, the raised arm shorter by "
                        "its offset, so its post stays as far from home along the corridors as on plus)")
    p.add_argument("--plain-episodes", type=int, metavar="N",
                   help="with --map-spread or --map-branch: play the first N keyed (noisy) episodes of each "
                        "generation on the map itself and only the others on variants (default 0)")
    p.add_argument("--sequential-episodes", type=int, metavar="S",
                   help="also score every team on S episodes of the sequential (real-world) protocol per "
                        "generation (with --robust-from first_solution: of the robust phase), the task's noise, "
                        "fresh per generation with --noise-draws per_generation (default 0)")
    p.add_argument("--sequential-plain", type=int, metavar="P",
                   help="with --sequential-episodes and --map-spread or --map-branch: play the first P of each "
                        "generation's sequential episodes on the map itself, the others on plus variants, so teams "
                        "are selected for the protocol on both (default 0: every one on a variant)")
    p.add_argument("--noise-free-variants", type=int, metavar="N",
                   help="with --map-spread or --map-branch: also score every team on N noise-free episodes per "
                        "generation on plus variants of their own (with --robust-from first_solution: of the robust "
                        "phase), so the variants' turns are rewarded without the noise's luck (default 0)")
    p.add_argument("--robust-from", choices=ROBUST_FROM,
                   help="with --noise: start (default: every generation is scored under noise) or first_solution "
                        "(noise-free, exactly the run without noise, until the first solution; the generations "
                        "after it are scored under noise and harden the solved population)")
    p.add_argument("--robust-delay", type=int, metavar="G",
                   help="with --robust-from first_solution: G noise-free generations after the first solution "
                        "before the noisy ones, so the solution spreads through the population first (default 0)")
    p.add_argument("--noise-free-branch", type=float, metavar="B",
                   help="with --robust-from first_solution (map plus): before the robust phase, score every team on "
                        "two noise-free episodes, plus and a plus variant whose side arms leave the top arm at "
                        "offsets drawn from [0, B] cm (new each generation; drawn as --branch-sides says), so a first "
                        "solution also solves an asymmetric crossing (default 0: plus alone, the faithful run)")
    p.add_argument("--diversity", type=float, metavar="W",
                   help="behavioural diversity: NEAT selects by fitness + W x the mean distance (cm) of a team's "
                        "robot end positions to its nearest teams in the generation (default 0: fitness alone, as "
                        "the paper); the task's fitness still picks champions and decides solved")
    p.add_argument("--diversity-k", type=int, metavar="K",
                   help="nearest teams the diversity bonus averages over (default 15)")
    p.add_argument("--reflex-arc", action="store_true", default=None,
                   help="beyond the paper: the reflex's side branches (a wall close left or right of a robot asked "
                        "to go forward) turn away and drive at speed instead of keeping the robot's velocity, so a "
                        "standing robot cannot deadlock against a wall (default: the original's reflex; the team's "
                        "champion files record it and every evaluation and deploy drives it so)")
    p.add_argument("--reflex-arc-from", choices=REFLEX_ARC_FROM,
                   help="with --reflex-arc: start (default: every generation) or robust_phase (with --robust-from "
                        "first_solution: the original's reflex until the robust phase, so the search is the "
                        "faithful run's and only the hardening uses the arcing reflex)")
    p.add_argument("--input-ceiling", type=float, metavar="C",
                   help="beyond the paper: a sensor value at or above C (in [0.5, 1]) reads 1, so the sensor noise "
                        "cannot move the input of open space (default 1: the original's encoding; the champion "
                        "files record it and every evaluation and deploy encodes the team's inputs so)")
    p.add_argument("--fitness-memory", choices=FITNESS_MEMORY,
                   help="under noise with --noise-draws per_generation: generation (default: a team's fitness is "
                        "its score in this generation, as the paper), lifetime (the mean of its scores over every "
                        "generation it was scored in; the archive keeps the best team that solved every episode of "
                        "at least 3 generations), so luck in a few episodes does not pick the teams, or archive "
                        "(NEAT selects by the generation's score, the archive keeps lifetime leaders)")
    p.add_argument("--restart-every", type=int, metavar="G",
                   help="until the first solution, start from a fresh population every G generations (default 0: "
                        "never, as the paper); the generation count and the champion carry on")


def _train_parser(sub) -> None:
    p = sub.add_parser("train", help="evolve a team (writes config, log, checkpoint, champion, summary, plot)")
    p.add_argument("--mode", choices=MODES, help="policy geometry (default situational)")
    p.add_argument("--generations", type=int, help="generations to run (default 1000, as the paper)")
    p.add_argument("--pop", type=int, help="population size (default 500, as the paper)")
    p.add_argument("--seed", type=int, help="the run's only seed (default 0)")
    p.add_argument("--init", choices=INITS, help="initial population: iros2011 (default: the paper's seed genome, "
                                                 "whose sign(z)*x modules make mirror-symmetric teams) or minimal "
                                                 "(every CPPN input wired to both outputs)")
    p.add_argument("--map", help="training map (default plus)")
    p.add_argument("--episodes", type=int, help="episodes per evaluation (default 1; >1 only with noise)")
    p.add_argument("--evaluate-modules", action=argparse.BooleanOptionalAction, default=None,
                   help="evaluate the seed's Multiply modules, as the paper describes them (default); "
                        "--no-evaluate-modules reproduces the original code, where they output 0")
    p.add_argument("--stop-when-solved", action="store_true", default=None, help="stop at the first solution")
    p.add_argument("--after-solved", type=int, metavar="G",
                   help="with --stop-when-solved, run G more generations so the archive gathers alternative "
                        "solutions for the generalisation test (default 0)")
    _fidelity_and_robustness_options(p)
    p.add_argument("--config", type=Path, help="TOML or JSON file with EvolutionConfig fields (flags override it)")
    p.add_argument("--out", type=Path, default=Path("runs/latest"), help="run folder (default runs/latest)")
    p.add_argument("--resume", action="store_true", help="continue the run in --out from its checkpoint")
    p.add_argument("--overwrite", action="store_true", help="remove the run --out holds before starting")
    p.add_argument("--gif", action="store_true", help="also render the champion's episode to champion.gif")
    p.add_argument("--quiet", action="store_true", help="no progress display")


def _eval_parser(sub) -> None:
    p = sub.add_parser("eval", help="score a saved champion on any map and engine")
    p.add_argument("champion", type=Path, help="a champion.json (a run's best team, or one from its archive/)")
    p.add_argument("--map", default="plus",
                   help="plus (the training map, default), asymmetric_plus (the paper's test map) or the path of "
                        "a map JSON file")
    p.add_argument("--engine", default="kinematic", choices=["kinematic", "pymunk"],
                   help="kinematic: the compiled simulator the team was trained in (default); pymunk: contact "
                        "physics, for robots that bump into each other")
    p.add_argument("--episodes", type=int,
                   help="episodes to average (default 1, 10 with --noise-parts; without noise every episode is the "
                        "same, so more than one only matters with --noise or a noise level)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the noise and start perturbations (default 0); same seed, same scores")
    p.add_argument("--noise", default="none", choices=sorted(NOISE_PRESETS),
                   help="noise preset: none, generalization (the generalisation test's), or robot (its motion noise "
                        "with a real Khepera III's IR sensors, as the emulator models them, and a reflex that reads "
                        "them, as a robot's does)")
    for name, what in (("sensor-noise", "percent: each IR input gets +- this/100, uniform"),
                       ("effector-noise", "percent: speed and turn rate scaled by 1 +- this/100 each tick"),
                       ("heading-noise", "radians: largest heading perturbation per tick"),
                       ("start-jitter-xy", "cm: largest shift of a start position (uniform in a square)"),
                       ("start-jitter-heading", "radians: largest change of a start heading")):
        p.add_argument(f"--{name}", type=float, help=f"override one noise level of the preset, in {what}")
    p.add_argument("--protocol", default="training", choices=["training", "sequential"],
                   help="training: all robots called at tick 690 (team fitness); sequential: the paper's "
                        "real-world protocol, robots called one at a time, robots see and bump each other; "
                        "it reports stages: 3 per robot (reached its own post, came home when called, went "
                        "back out to its post), 9 for a team of three")
    p.add_argument("--video", type=Path, help="write a GIF of the (first) episode")
    p.add_argument("--plot", type=Path, help="write a PNG of the trajectories of the (first) episode")
    p.add_argument("--margins", action="store_true",
                   help="also report how firmly the team decides (training protocol, first episode): the "
                        "fraction of decisions that are exact ties or near-ties (< 0.001), a sign of a "
                        "team that noise or real robots will break")
    p.add_argument("--noise-parts", action="store_true",
                   help="which part of the noise breaks the team: the same episodes (--episodes, default here 10) "
                        "under the whole noise, none, and each noise level of the preset alone, one line each "
                        "(needs --noise generalization or a noise level)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")


def _probe_parser(sub) -> None:
    p = sub.add_parser("probe", help="which part of the test map a team handles: one noise-free sequential episode on "
                                     "each plus variant that changes one thing (one-sided openings, arm lengths)")
    p.add_argument("champion", type=Path, help="a champion.json (a run's best team, or one from its archive/)")
    p.add_argument("--engine", default="pymunk", choices=["kinematic", "pymunk"],
                   help="pymunk: robots bump into each other, as the transfer test (default); kinematic: the "
                        "compiled simulator's motion")
    p.add_argument("--only", nargs="+", metavar="PROBE", help="play only these probes (default: all)")
    p.add_argument("--json", action="store_true", help="print the probes' results as JSON")


def cmd_probe(args) -> int:
    from .evaluation.probes import probe_summary, probe_team
    from .training.champion import Champion

    rows = probe_team(Champion.load(args.champion), engine=args.engine,
                      names=tuple(args.only) if args.only else None)
    print(json.dumps(rows, indent=1) if args.json else probe_summary(rows))
    return 0


def _generalize_parser(sub) -> None:
    p = sub.add_parser("generalize", help="rank a run's archived solutions under noise (the paper's test)")
    p.add_argument("run_dir", type=Path,
                   help="a run folder of `mahn-evo train`; its archive/ solutions (or champion.json) are ranked, "
                        "and the ranking is written there as generalization.json and .csv")
    p.add_argument("--episodes", type=int, default=25,
                   help="noisy episodes per solution (default 25, as the paper); every solution gets the same "
                        "noise, so the ranking compares teams, not luck")
    p.add_argument("--map", default="plus",
                   help="map to test on: plus (default), asymmetric_plus or the path of a map JSON file")
    p.add_argument("--seed", type=int, default=0, help="seed of the noise (default 0); same seed, same ranking")
    p.add_argument("--noise", default="generalization",
                   help="noise preset: generalization (default: sensor, turning and motion noise, start "
                        "jitter) or none")
    p.add_argument("--json", action="store_true", help="print the ranking as JSON instead of a table")


def _final_validation_parser(sub) -> None:
    from .evaluation.final_population import ENGINES

    p = sub.add_parser("final-validation",
                       help="score every team of a run's final population on fresh noisy episodes and archive the "
                            "best noise-free solution (post-evaluation; mahn_evo.evaluation.final_population)")
    p.add_argument("run_dirs", type=Path, nargs="+", metavar="run_dir",
                   help="run folders of `mahn-evo train` or an experiment's runs/; each gets "
                        "archive/solution_final_*.json and final_validation.json")
    p.add_argument("--episodes", type=int, default=25,
                   help="validation episodes per team (default 25; the generalisation noise, the run's seed, "
                        "keys of their own)")
    p.add_argument("--sequential", type=int, default=0, metavar="T",
                   help="play the T best teams of that ranking through the sequential protocol under the same "
                        "noise on the run's map and archive the one that succeeds most often (default 0: choose "
                        "by the training protocol alone)")
    p.add_argument("--sequential-episodes", type=int, default=10,
                   help="sequential-protocol episodes per team with --sequential (default %(default)s; seeds from "
                        "2^30, never the transfer test's)")
    p.add_argument("--family-episodes", type=int, default=0, metavar="F",
                   help="with --sequential (a run trained on plus variants): those teams also play F noisy "
                        "sequential episodes on the run's own variants (keys never trained on), and the choice "
                        "counts both: success on the training family predicts the test map (default 0: the map "
                        "alone)")
    p.add_argument("--engine", choices=ENGINES, default="pymunk",
                   help="where the sequential stage plays: pymunk (default: the transfer test's engine, robots "
                        "bump into each other) or batch (the compiled core's protocol, as training plays it: about "
                        "50 times faster, so --sequential can cover every candidate)")
    p.add_argument("--noise", choices=TEST_NOISES,
                   help="noise preset of every validation episode (default: the run's own, generalization for runs "
                        "evolved without noise)")


def cmd_final_validation(args) -> int:
    from .evaluation.final_population import validate_final_population

    for run in args.run_dirs:
        record = validate_final_population(run, episodes=args.episodes, sequential_teams=args.sequential,
                                           sequential_episodes=args.sequential_episodes,
                                           family_episodes=args.family_episodes, engine=args.engine,
                                           noise=args.noise)
        chosen = record["chosen"]
        if chosen is None:
            print(f"{run}: no team of generation {record['generation']} solves the noise-free task; nothing archived")
        else:
            seq = (f"; {chosen['sequential_successes']} of {record['sequential']['episodes']} sequential episodes"
                   if "sequential" in record else "")
            if "family_successes" in chosen:
                seq += f" and {chosen['family_successes']} of {args.family_episodes} on its plus variants"
            print(f"{run}: {chosen['file']} (reading {chosen['reading']}): solved {chosen['solved_fraction']:.2f} "
                  f"of {record['episodes']} validation episodes, mean fitness {chosen['mean_fitness']:.1f}{seq}")
    return 0


def _experiment_parser(sub) -> None:
    from .evaluation.final_population import ENGINES
    from .experiment.backends import BACKENDS
    from .experiment.plan import GENERAL_FROM, GENERAL_RANKS, TRANSFER_NOISES, ExperimentPlan

    d = ExperimentPlan()
    p = sub.add_parser("experiment", help="the paper's table: seeded runs per mode, generalisation, transfer, figures")
    p.add_argument("--modes", nargs="+", default=list(d.modes), choices=MODES,
                   help="policy geometries to compare (default: %(default)s)")
    p.add_argument("--runs", type=int, default=d.runs, help=f"runs per mode (default {d.runs}, as the paper)")
    p.add_argument("--seed", type=int, default=d.seed, help="run i of each mode uses seed+i (default %(default)s)")
    p.add_argument("--generations", type=int, default=d.generations, help="at most (default %(default)s)")
    p.add_argument("--pop", type=int, default=d.population, help="population (default %(default)s)")
    p.add_argument("--init", choices=INITS, help=f"initial population (default {d.init})")
    p.add_argument("--evaluate-modules", action=argparse.BooleanOptionalAction, default=None,
                   help=f"evaluate the seed's Multiply modules (default {d.evaluate_modules})")
    p.add_argument("--episodes", type=int, help="episodes per team per generation (default 1)")
    _fidelity_and_robustness_options(p)
    p.add_argument("--map", default=d.map, help="training map (default %(default)s)")
    p.add_argument("--after-solved", type=int, default=d.after_solved,
                   help="generations a run continues after its first solution, so the generalisation test has "
                        "alternatives to choose from (default %(default)s)")
    # the analysis options default to None so that --report-only can tell which ones were given
    p.add_argument("--top", type=int, help=f"most general solutions per mode to transfer (default {d.top}, as the "
                                           "paper)")
    p.add_argument("--general-episodes", type=int,
                   help=f"noisy episodes of the generalisation test (default {d.general_episodes})")
    p.add_argument("--transfer-episodes", type=int,
                   help=f"noisy episodes per transfer test (default {d.transfer_episodes})")
    p.add_argument("--final-validation", type=int, metavar="N",
                   help="before the report, score every team of each finished run's final population on N "
                        "validation episodes and add its best noise-free solution to the run's archive (`mahn-evo "
                        f"final-validation`; default {d.final_validation}: none)")
    p.add_argument("--final-sequential", type=int, metavar="T",
                   help="with --final-validation: its T best teams also play 10 noisy episodes of the sequential "
                        "protocol on the training map and the most successful is archived (`mahn-evo "
                        f"final-validation --sequential T`; default {d.final_sequential}: none)")
    p.add_argument("--final-family", type=int, metavar="F",
                   help="with --final-sequential (runs trained on plus variants): those teams also play F noisy "
                        "sequential episodes on the run's own variants and the choice counts both (`mahn-evo "
                        f"final-validation --family-episodes F`; default {d.final_family}: none)")
    p.add_argument("--final-engine", choices=ENGINES,
                   help="the engine of the final validation's sequential stage (`mahn-evo final-validation "
                        f"--engine`; default {d.final_engine})")
    p.add_argument("--general-from", choices=GENERAL_FROM,
                   help="each run's team for the generalisation ranking and the transfer tests: archive (its most "
                        "general archived solution) or final_validation (the final validation's pick, so a team "
                        f"chosen for the sequential protocol is the one tested; default {d.general_from})")
    p.add_argument("--general-rank", choices=GENERAL_RANKS,
                   help="how the runs' teams are ranked for the most general: generalization (the paper's test, "
                        "noisy training episodes on the map) or protocol (with --general-from final_validation and "
                        "--final-sequential: the pick's successes in the final validation's noisy sequential "
                        f"episodes on the map and its plus variants; default {d.general_rank})")
    p.add_argument("--transfer-noise", choices=TRANSFER_NOISES,
                   help="noise of the transfer tests' noisy columns: generalization (the generalisation test's, "
                        "default) or robot (a real Khepera III's IR sensors and a reflex that reads them)")
    p.add_argument("--max-cycles", type=int, default=d.max_cycles, help=argparse.SUPPRESS)
    p.add_argument("--signal-tick", type=int, default=d.signal_tick, help=argparse.SUPPRESS)
    p.add_argument("--config", type=Path, help="TOML or JSON file whose `neat` table overrides NEAT settings")
    p.add_argument("--out", type=Path, default=Path("runs/experiment"), help="experiment folder")
    p.add_argument("--backend", choices=BACKENDS, default="local",
                   help="local processes (default) or a Ray cluster; same results for the same seeds")
    p.add_argument("--address", help="Ray cluster address (default: start a local Ray instance)")
    p.add_argument("--workers", type=int, default=2, help="runs at a time (default %(default)s)")
    p.add_argument("--only-seeds", type=int, nargs="+", metavar="SEED",
                   help="run only these of the experiment's seeds (e.g. its runs split across machines, or lost "
                        "runs redone); each run is the one the whole experiment makes")
    p.add_argument("--no-analysis", action="store_true", help="only run the runs")
    p.add_argument("--report-only", action="store_true",
                   help="start no runs: write the results of the runs finished so far (e.g. while the experiment "
                        "runs in another shell), with the folder's saved plan; --top, --general-episodes, "
                        "--transfer-episodes, --final-validation and --final-sequential, when given, replace the "
                        "saved ones (experiment.json is updated)")


def _screen_parser(sub) -> None:
    p = sub.add_parser("screen", help="compare experiment folders of candidate configurations on their common "
                                      "seeds (solved, Fisher's exact test against a baseline, survival plot)")
    p.add_argument("variants", nargs="+", type=Path, help="experiment folders, one per variant (the folder name "
                                                          "names the variant)")
    p.add_argument("--baseline", required=True, help="the variant the others are tested against (a folder name)")
    p.add_argument("--mode", choices=MODES, default="situational", help="mode compared (default %(default)s)")
    p.add_argument("--out", type=Path, required=True, help="folder for screen.json, screen.md, survival.png")
    p.add_argument("--generations", type=int,
                   help="compare at this common budget (no larger than any variant's generation limit): runs that "
                        "ran longer count as solved only by a solution within it (default: the variants' common "
                        "limit)")


def cmd_screen(args) -> int:
    from .experiment.screen import screen_markdown, write_screen

    print(screen_markdown(write_screen(args.variants, args.baseline, args.out, args.mode, args.generations)), end="")
    return 0


def experiment_plan(args: argparse.Namespace) -> ExperimentPlan:
    """The ExperimentPlan that `mahn-evo experiment`'s arguments ask for: the defaults, then a preset or --config
    file's evaluation settings, then the flags given."""
    from .experiment.plan import EVOLUTION_FIELDS, ExperimentPlan

    base = apply_preset(EvolutionConfig(), args.preset) if args.preset else EvolutionConfig()
    if args.config:
        base = load_config_file(args.config, base)
    neat = {k: v for k, v in base.neat.to_dict().items() if v != EvolutionConfig().neat.to_dict().get(k)}
    d = ExperimentPlan()
    chosen = {"init": args.init, "evaluate_modules": args.evaluate_modules, "cppn_activation": args.cppn_activation,
              "decision": args.decision, "symmetry": args.symmetry,
              "noise": args.noise, "episodes": args.episodes, "noise_draws": args.noise_draws,
              "aggregate": args.aggregate, "quantile": args.quantile,
              "noise_free_episode": args.noise_free_episode, "map_spread": args.map_spread,
              "map_branch": args.map_branch, "branch_sides": args.branch_sides,
              "plain_episodes": args.plain_episodes, "sequential_episodes": args.sequential_episodes,
              "sequential_plain": args.sequential_plain, "noise_free_variants": args.noise_free_variants,
              "robust_from": args.robust_from,
              "robust_delay": args.robust_delay, "noise_free_branch": args.noise_free_branch,
              "fitness_memory": args.fitness_memory, "diversity": args.diversity, "diversity_k": args.diversity_k,
              "restart_every": args.restart_every}
    # a preset or config file sets the evaluation fields (not the plan's scale: map and after_solved are flags)
    from_base = {k: getattr(base, k) for k in EVOLUTION_FIELDS if k in chosen and (args.preset or args.config)}
    if args.preset or args.config:
        if base.noise_preset is None:
            raise ValueError("an experiment names its task noise (--noise); the --config file sets other noise "
                             f"levels than the presets {sorted(NOISE_PRESETS)}")
        from_base["noise"] = base.noise_preset
    fields = {k: getattr(d, k) for k in chosen} | from_base | {k: v for k, v in chosen.items() if v is not None}
    return ExperimentPlan(modes=tuple(args.modes), runs=args.runs, seed=args.seed, generations=args.generations,
                          population=args.pop, map=args.map, after_solved=args.after_solved,
                          # with --report-only the given report options replace the saved plan's (run_experiment)
                          **{k: d.to_dict()[k] if v is None or args.report_only else v
                             for k, v in _analysis_options(args).items()},
                          max_cycles=args.max_cycles, signal_tick=args.signal_tick, neat=neat,
                          reflex_arc=base.task.reflex_arc if args.reflex_arc is None else args.reflex_arc,
                          reflex_arc_from=args.reflex_arc_from or base.reflex_arc_from,
                          input_ceiling=base.task.input_ceiling if args.input_ceiling is None else args.input_ceiling,
                          **fields)


def _analysis_options(args) -> dict[str, Any]:
    """The report's options as given on the command line (None: not given)."""
    return {"top": args.top, "general_episodes": args.general_episodes, "transfer_episodes": args.transfer_episodes,
            "final_validation": args.final_validation, "final_sequential": args.final_sequential,
            "final_family": args.final_family, "final_engine": args.final_engine,
            "general_from": args.general_from, "general_rank": args.general_rank,
            "transfer_noise": args.transfer_noise}


def cmd_experiment(args) -> int:
    from .experiment.runner import run_experiment

    if args.only_seeds is not None and args.report_only:
        raise ValueError("--only-seeds says which runs to run; --report-only runs none (it reports on every run "
                         "finished in the folder)")
    plan = experiment_plan(args)
    import signal

    def _terminate(signum, frame):  # `kill PID` stops the workers too, like Ctrl-C
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, _terminate)
    try:
        results = run_experiment(plan, args.out, backend=args.backend, workers=args.workers, address=args.address,
                                 analyse=not args.no_analysis, run=not args.report_only,
                                 analysis={k: v for k, v in _analysis_options(args).items() if v is not None},
                                 log=lambda m: print(m, flush=True), only_seeds=args.only_seeds)
    except KeyboardInterrupt:
        print(f"\ninterrupted; run the same command again to resume ({args.out})", file=sys.stderr)
        return 130
    if results:
        print(f"results: {args.out / 'results.md'}")
    return 0


def cmd_generalize(args) -> int:
    from .evaluation.generalize import generalize
    from .evaluation.task_setup import task_params

    rows = generalize(args.run_dir, episodes=args.episodes, map=args.map, params=task_params(args.noise),
                      seed=args.seed)
    if args.json:
        print(json.dumps(rows, indent=1))
    else:
        print(f"{'rank':>4}  {'generation':>10}  {'solved':>6}  {'mean fitness':>12}  file")
        for r in rows:
            print(f"{r['rank']:4d}  {r['generation']:10d}  {r['solved_fraction']:6.2f}  {r['mean_fitness']:12.3f}  "
                  f"{r['file']}")
    return 0


def _progress_printer(quiet: bool, total: int):
    if quiet:
        return None, None
    if sys.stdout.isatty():
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        prog = Progress(TextColumn("[bold]gen"), MofNCompleteColumn(), BarColumn(), TextColumn("{task.description}"),
                        TimeElapsedColumn())
        task = prog.add_task("", total=total)

        def update_bar(p):
            prog.update(task, completed=p.generation + 1, description=(
                f"best {p.best_fitness:8.3f}  mean {p.mean_fitness:7.3f}  species {p.n_species:3d}  "
                f"solved {'yes' if p.first_solved is not None else 'no '}  {p.seconds:.2f} s/gen"))
        return prog, update_bar

    def print_line(p):
        if p.generation % 10 == 0 or p.generation + 1 == p.generations or p.solved:
            print(f"gen {p.generation:5d}  best {p.best_fitness:9.4f}  mean {p.mean_fitness:8.4f}  "
                  f"species {p.n_species:3d}  solved {'yes' if p.first_solved is not None else 'no'}  "
                  f"{p.seconds:.2f} s/gen", flush=True)
    return None, print_line


def cmd_train(args) -> int:
    from .training.trainer import Trainer

    base = EvolutionConfig()
    if args.preset:
        base = apply_preset(base, args.preset)
    if args.config:
        base = load_config_file(args.config, base)
    overrides = dict(mode=args.mode, generations=args.generations, pop=args.pop, seed=args.seed, init=args.init,
                     map=args.map, episodes=args.episodes, evaluate_modules=args.evaluate_modules,
                     stop_when_solved=args.stop_when_solved, after_solved=args.after_solved,
                     cppn_activation=args.cppn_activation, decision=args.decision, symmetry=args.symmetry,
                     noise_draws=args.noise_draws,
                     aggregate=args.aggregate,
                     quantile=args.quantile, noise_free_episode=args.noise_free_episode, map_spread=args.map_spread,
                     map_branch=args.map_branch, branch_sides=args.branch_sides,
                     plain_episodes=args.plain_episodes, sequential_episodes=args.sequential_episodes,
                     sequential_plain=args.sequential_plain, noise_free_variants=args.noise_free_variants,
                     diversity=args.diversity, diversity_k=args.diversity_k, restart_every=args.restart_every)
    if args.resume and (args.out / "config.json").exists() and not args.config and not args.preset:
        from .storage.files import read_versioned_json

        base = EvolutionConfig.from_saved(read_versioned_json(args.out / "config.json", "config"))
    config = base.with_overrides(**overrides)
    if args.noise is not None:
        config = config.with_noise(args.noise)
    # after the noise: robust_from "first_solution" needs a noisy task
    config = config.with_overrides(robust_from=args.robust_from, robust_delay=args.robust_delay,
                                   noise_free_branch=args.noise_free_branch, fitness_memory=args.fitness_memory)
    if args.reflex_arc is not None or args.reflex_arc_from is not None:
        config = replace(config, task=replace(config.task, reflex_arc=config.task.reflex_arc if args.reflex_arc is None
                                              else args.reflex_arc),
                         reflex_arc_from=args.reflex_arc_from or config.reflex_arc_from)
    if args.input_ceiling is not None:
        config = replace(config, task=replace(config.task, input_ceiling=args.input_ceiling))
    from .storage.folder_lock import folder_lock

    with folder_lock(args.out, "run folder"):
        return _run_training(args, Trainer(config, args.out, resume=args.resume, overwrite=args.overwrite), config)


def _run_training(args, trainer, config: EvolutionConfig) -> int:
    prog, on_gen = _progress_printer(args.quiet, config.generations)
    try:
        if prog is not None:
            with prog:
                summary = trainer.run(on_gen)
        else:
            summary = trainer.run(on_gen)
    except KeyboardInterrupt:
        trainer.finish()
        print(f"\ninterrupted after generation {trainer.generation}; continue with: "
              f"mahn-evo train --out {args.out} --resume", file=sys.stderr)
        return 130
    if args.gif and (args.out / "champion.json").exists():
        from .evaluation.eval_champion import evaluate_champion

        evaluate_champion(args.out / "champion.json", map=config.map, video=args.out / "champion.gif")
        _trajectory_png(args.out / "champion.json", config.map, args.out / "champion.png")
    print(json.dumps(summary, indent=1))
    return 0


def _trajectory_png(champion_path: Path, map_name: str, out_png: Path) -> dict:
    from mahn_envs.core import BatchSim

    from .plots import trajectory_plot
    from .training.champion import Champion

    champ = Champion.load(champion_path)
    sim = BatchSim(map_name, 1, champ.task())  # driven with the team's own settings (reflex, input ceiling)
    res = sim.run_controllers(champ.controllers, record=True)
    assert res.trajectories is not None  # record=True records them
    trajectory_plot(sim.world, res.trajectories[0], out_png,
                    title=f"{champ.mode} champion (gen {champ.generation}): fitness {res.fitness[0]:.2f}, "
                          f"solved {bool(res.solved[0])}", signal_tick=sim.params.signal_tick)
    return {"fitness": float(res.fitness[0])}


def cmd_eval(args) -> int:
    from .evaluation.eval_champion import evaluate_champion
    from .evaluation.task_setup import task_params

    params = task_params(args.noise, sensor_noise=args.sensor_noise, effector_noise=args.effector_noise,
                         heading_noise=args.heading_noise, start_jitter_xy=args.start_jitter_xy,
                         start_jitter_heading=args.start_jitter_heading)
    if args.noise_parts:
        return _eval_noise_parts(args, params, 10 if args.episodes is None else args.episodes)
    if args.episodes is None:
        args.episodes = 1
    if args.protocol == "sequential":
        from .evaluation.eval_champion import champion_policy
        from .evaluation.protocols import sequential, sequential_summary
        from .training.champion import Champion

        champ = Champion.load(args.champion)
        params = champ.task(params)
        policy = champion_policy(champ)
        result = sequential(policy, map=args.map, params=params, episodes=args.episodes, seed=args.seed)
        if args.video or args.plot:  # the first episode again, filmed / recorded
            from .evaluation.protocols import sequential_episode
            from .plots import save_gif, trajectory_plot

            frames: list | None = [] if args.video else None
            ep = sequential_episode(policy, map=args.map, params=params, seed=args.seed, record=True,
                                    frames=frames)
            if frames is not None:  # exactly when args.video
                save_gif(frames, args.video, fps=15)
            if args.plot:
                from mahn_envs.maps import load_map

                assert ep.trajectory is not None  # record=True records it
                trajectory_plot(load_map(args.map), ep.trajectory, args.plot,
                                title=f"sequential protocol on {args.map}: "
                                      f"{'success' if ep.success else 'fail'} ({ep.stages_completed}/9 stages)")
        result.update(protocol="sequential", map=args.map, solved_fraction=float(sum(result["solved"])) /
                      len(result["solved"]))
        if args.json:
            print(json.dumps(result, indent=1))
        else:
            print(sequential_summary(result, args.map))
        return 0
    result = evaluate_champion(args.champion, map=args.map, engine=args.engine, episodes=args.episodes,
                               params=params, seed=args.seed, video=args.video)
    if args.plot:
        _trajectory_png(args.champion, args.map, args.plot)
    if args.margins:
        from .evaluation.margins import decision_margins

        result["margins"] = decision_margins(args.champion, map=args.map, params=params, seed=args.seed)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(f"fitness {result['fitness']:.6f}  solved {result['solved']}  "
              f"({result['episodes']} episode(s), map {args.map}, engine {args.engine})")
        if args.margins:
            m = result["margins"]
            print(f"decisions {m['decisions']}: {100 * m['tied_fraction']:.1f}% exact ties, "
                  f"{100 * m['near_tie_fraction']:.1f}% near-ties (< 0.001); median margin "
                  f"{m['median_margin']:.3g}, median top output {m['median_top_output']:.7f}; "
                  f"{m['flipped']} decision(s) flipped by input jitter of +-{m['probe']:g}")
    return 0


def _eval_noise_parts(args, params, episodes: int) -> int:
    """`mahn-evo eval --noise-parts`: the team's episodes once per part of the noise."""
    from .evaluation.noise_parts import noise_parts, noise_parts_summary

    if args.video or args.plot or args.margins:
        raise ValueError("--noise-parts plays the episodes once per part of the noise: it does not combine with "
                         "--video, --plot or --margins (run those without it)")
    rows = noise_parts(args.champion, params, map=args.map, protocol=args.protocol, engine=args.engine,
                       episodes=episodes, seed=args.seed)
    if args.json:
        print(json.dumps({"map": args.map, "protocol": args.protocol, "episodes": episodes, "seed": args.seed,
                          "parts": rows}, indent=1))
    else:
        print(noise_parts_summary(rows, args.protocol, episodes, args.map))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="mahn-evo", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    _train_parser(sub)
    _eval_parser(sub)
    _probe_parser(sub)
    _generalize_parser(sub)
    _final_validation_parser(sub)
    _experiment_parser(sub)
    _screen_parser(sub)
    try:
        from .deploy import add_deploy_parser
    except ImportError:
        pass
    else:
        add_deploy_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command == "train":
            return cmd_train(args)
        if args.command == "eval":
            return cmd_eval(args)
        if args.command == "probe":
            return cmd_probe(args)
        if args.command == "generalize":
            return cmd_generalize(args)
        if args.command == "final-validation":
            return cmd_final_validation(args)
        if args.command == "experiment":
            return cmd_experiment(args)
        if args.command == "screen":
            return cmd_screen(args)
        return int(args.func(args) or 0)
    except (ValueError, TypeError, RuntimeError, OSError) as exc:  # OSError: an unwritable or missing path, a full disk
        print(f"mahn-evo: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
