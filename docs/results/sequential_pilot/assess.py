"""Pilot assessment: per run, final validation with the sequential stage (25 training-protocol episodes, the best
20 through 10 sequential episodes on plus), then the chosen team's robustness test (10 noisy sequential episodes
per map, episode seeds 1..10 as the experiment's transfer test) and its 25-episode generalisation score."""
import json
import sys
from pathlib import Path

import numpy as np

from mahn_evo.evaluation.eval_champion import champion_policy, evaluate_champion
from mahn_evo.evaluation.final_population import final_population, validate_final_population
from mahn_evo.evaluation.protocols import sequential
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.hyperneat.substrate import team_reading
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.training.champion import Champion

out = {}
for run in sys.argv[2:]:
    run = Path(run)
    rec = validate_final_population(run, episodes=25, sequential_teams=20, write=False)
    ch = rec["chosen"]
    if ch is None:
        out[run.name] = None
        print(run.name, "no solution", flush=True)
        continue
    config, pop = final_population(run)
    ctrl = team_reading(TeamEvaluator(config.evaluation).decode([pop.genomes[ch["index"]]]), ch["reading"]).team(0)
    champ = Champion(mode=config.mode, fitness=ch["mean_fitness"], solved=True, generation=pop.generation,
                     genome=pop.genomes[ch["index"]], controllers=ctrl, seed=config.seed, map=config.map,
                     reflex_arc=config.task.reflex_arc)
    noisy = champ.task(task_params("generalization"))
    test = {m: float(np.mean(sequential(champion_policy(champ), map=m, params=noisy, episodes=10, seed=1)["solved"]))
            for m in ("plus", "asymmetric_plus")}
    gen = evaluate_champion(champ, map="plus", episodes=25, params=noisy, seed=0)["solved_fraction"]
    out[run.name] = {"generation": pop.generation, "chosen": ch, "sequential_test": test, "generalisation": gen,
                     "robust": all(v >= 0.8 for v in test.values())}
    print(run.name, pop.generation, "val seq", ch.get("sequential_successes"), "train-val", ch["solved_fraction"],
          "test", test, "general", gen, flush=True)
Path(sys.argv[1]).write_text(json.dumps(out, indent=1))
