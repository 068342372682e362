"""Which part of a robot's sensing breaks a team: published champions in the compiled core under sensor variants.

Each champion plays N training-protocol episodes on `plus` (episode keys 0..N-1, seed 1) with no motion noise and
  - the generalisation test's sensors: +-5 % uniform, the reflex reading the noise-free rays (the original's);
  - the same, the reflex reading the noisy values (TaskParams.reflex_reads_noise);
  - a real Khepera III's sensors (TaskParams.sensor_model "khepera", sensor_noise 100: the emulator's model);
  - those, the reflex reading them: what the emulator and a real robot do;
and once with the whole `--noise robot` preset (the generalisation test's motion noise and start jitter too).
One JSON line per champion: the fraction of episodes solved under each.

Usage: python docs/results/emulator_check/sensor_parts.py N CHAMPION.json ... > sensor_parts.jsonl
"""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from mahn_envs.core.batch import BatchSim
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.champion import Champion

RESULTS = Path(__file__).resolve().parents[1]


def variants() -> dict:
    quiet = task_params("none")
    return {
        "uniform": replace(quiet, sensor_noise=5.0),
        "uniform_reflex_reads": replace(quiet, sensor_noise=5.0, reflex_reads_noise=True),
        "khepera": replace(quiet, sensor_noise=100.0, sensor_model="khepera"),
        "khepera_reflex_reads": replace(quiet, sensor_noise=100.0, sensor_model="khepera", reflex_reads_noise=True),
        "robot_preset": task_params("robot"),
    }


def main() -> None:
    n = int(sys.argv[1])
    for path in sys.argv[2:]:
        champ = Champion.load(path)
        row: dict = {"champion": str(Path(path).resolve().relative_to(RESULTS)), "episodes": n}
        for name, params in variants().items():
            sim = BatchSim("plus", n, champ.task(params))
            res = sim.run_controllers(champ.controllers, seed=1, episode_keys=np.arange(n))
            row[name] = round(float(res.solved.mean()), 2)
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
