"""Does the README's quick run leave a champion that keeps its fitness on (emulated) robots?

For each run folder: the champion's training fitness (what the run reports), its noise-free fitness in the
simulator, its mean fitness over 20 episodes under the robot noise and under the generalisation noise (the
simulator's kinematic core, seeds 0-19), and its fitness through `mahn-evo deploy --emulate` (the Khepera III
emulator: continuous wheel motion, 12-bit sensor counts with a real sensor's noise) on a virtual clock, emulator
seeds 0-2, so the numbers do not depend on the machine's load.

Issue 15's criterion, fixed before the runs were measured: the emulated fitness (mean of the 3 seeds) within 20 %
of the training fitness (`within_20_training`); also given against the noise-free fitness (`within_20_noise_free`).
A team that barely moves meets it too (4.1 in training, 4.1 emulated), so the summary also counts the champions
that keep the quick run's patrol level through the emulator (emulated fitness >= PATROL_LEVEL).

    python docs/results/quick_run_transfer/transfer.py OUT.json RUN_DIR [RUN_DIR ...]
    python docs/results/quick_run_transfer/transfer.py --table OUT.json     # the page's tables
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from mahn_envs.hardware import Link, RetryPolicy
from mahn_envs.hardware.clock import VirtualClock
from mahn_evo.deploy import deploy
from mahn_evo.evaluation.eval_champion import evaluate_champion
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.storage.files import atomic_write_json, read_versioned_json, versioned
from mahn_evo.training.champion import Champion

NOISY_EPISODES = 20
EMULATOR_SEEDS = (0, 1, 2)
TOLERANCE = 0.2
#: the fitness of the quick run's patrol plateau (the README's champion: 54.2; every post patrolled from ~40)
PATROL_LEVEL = 40.0


def within(value: float, reference: float) -> bool:
    return abs(value - reference) <= TOLERANCE * abs(reference)


def measure(run: Path) -> dict:
    path = run / "champion.json"
    champ = Champion.load(path)
    config = read_versioned_json(run / "config.json", "config")
    clean = evaluate_champion(champ, episodes=1)
    robot = evaluate_champion(champ, episodes=NOISY_EPISODES, params=task_params("robot"))
    general = evaluate_champion(champ, episodes=NOISY_EPISODES, params=task_params("generalization"))
    emulated = [deploy(path, emulate=True, emulator_seed=s, clock=VirtualClock(),
                       env_kwargs={"link": Link(retry=RetryPolicy(timeout=2.0))},
                       log_path=run / f"emulator_s{s}.csv").team_fitness for s in EMULATOR_SEEDS]
    mean_emulated = float(np.mean(emulated))
    return {"run": run.name, "seed": config["seed"], "training_fitness": champ.fitness,
            "generation": champ.generation, "noise_free_fitness": clean["fitness"],
            "robot_noise_mean_fitness": robot["fitness"], "generalization_noise_mean_fitness": general["fitness"],
            "emulator_fitness": emulated, "emulator_mean_fitness": mean_emulated,
            "within_20_training": within(mean_emulated, champ.fitness),
            "within_20_noise_free": within(mean_emulated, clean["fitness"])}


def table(path: Path) -> str:
    rows = read_versioned_json(path, "quick_run_transfer")["measures"]
    lines = ["| run | training | noise-free | robot noise (20) | generalisation noise (20) | emulator (3 seeds) | "
             "within 20 % of training / noise-free |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        emu = ", ".join(f"{v:.1f}" for v in r["emulator_fitness"])
        lines.append(f"| {r['run']} | {r['training_fitness']:.1f} | {r['noise_free_fitness']:.1f} | "
                     f"{r['robot_noise_mean_fitness']:.1f} | {r['generalization_noise_mean_fitness']:.1f} | {emu} | "
                     f"{'yes' if r['within_20_training'] else 'no'} / "
                     f"{'yes' if r['within_20_noise_free'] else 'no'} |")
    by_variant: dict[str, list[dict]] = {}
    for r in rows:
        by_variant.setdefault(r["run"].rsplit("_s", 1)[0], []).append(r)
    lines += ["", "| variant | runs | within 20 % of training | of noise-free | "
              f"emulated >= {PATROL_LEVEL:g} (seeds) | median emulator fitness |", "|---|---|---|---|---|---|"]
    for name, rs in by_variant.items():
        patrol = [r["seed"] for r in rs if r["emulator_mean_fitness"] >= PATROL_LEVEL]
        lines.append(f"| {name} | {len(rs)} | {sum(r['within_20_training'] for r in rs)} | "
                     f"{sum(r['within_20_noise_free'] for r in rs)} | {len(patrol)} "
                     f"({', '.join(map(str, patrol)) or '-'}) | "
                     f"{np.median([r['emulator_mean_fitness'] for r in rs]):.1f} |")
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    if len(argv) == 2 and argv[0] == "--table":
        print(table(Path(argv[1])))
        return 0
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    out, runs = Path(argv[0]), [Path(a) for a in argv[1:]]
    rows = [measure(r) for r in runs]
    atomic_write_json(out, versioned("quick_run_transfer", {
        "measures": rows, "noisy_episodes": NOISY_EPISODES, "emulator_seeds": list(EMULATOR_SEEDS),
        "tolerance": TOLERANCE}))
    for r in rows:
        print(json.dumps(r))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
