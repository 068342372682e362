"""Seconds per generation at paper scale and where they go.

Population 500, situational policy geometry, full 1364-tick episodes on the plus map: CPPN compile + substrate
decoding, evaluation in the compiled batch core (both cores), NEAT reproduction, and checkpoint writing.
Target on a 2-core machine: <= 0.5 s per generation.  For scale: the original C# system takes ~12 s here.
Usage: python benchmarks/bench_generation.py [--pop 500] [--generations 8] [--init minimal]
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from mahn_envs.core import TaskParams  # noqa: E402
from mahn_evo.training.config import EvolutionConfig  # noqa: E402
from mahn_evo.training.trainer import Trainer  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pop", type=int, default=500)
    ap.add_argument("--generations", type=int, default=8)
    ap.add_argument("--mode", default="situational")
    ap.add_argument("--init", default="minimal", help="minimal gives varied networks from generation 0")
    args = ap.parse_args()
    cfg = EvolutionConfig(mode=args.mode, init=args.init, generations=args.generations + 2).with_overrides(pop=args.pop)
    with tempfile.TemporaryDirectory() as d:
        tr = Trainer(cfg, d)
        tr.step()  # warm up (compiled code loads from cache)
        parts = {"decode": [], "evaluate": [], "reproduce": [], "checkpoint": []}
        total = []
        for _ in range(args.generations):
            t0 = time.perf_counter()
            genomes = tr.population.ask()
            controllers = tr.evaluator.decode(genomes)
            t1 = time.perf_counter()
            fitness, _ = tr.evaluator.score(controllers)
            t2 = time.perf_counter()
            tr.population.tell(fitness)
            t3 = time.perf_counter()
            tr._checkpoint()
            t4 = time.perf_counter()
            for k, v in zip(parts, (t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
                parts[k].append(v)
            total.append(t4 - t0)
    mean = {k: float(np.mean(v)) for k, v in parts.items()}
    tot = float(np.mean(total))
    steps = args.pop * 3 * TaskParams().max_cycles
    print(f"population {args.pop}, {args.mode}, {args.generations} generations, {os.cpu_count()} cores")
    print(f"seconds per generation: {tot:.3f}   (target <= 0.5; original C# ~12 s)")
    for k, v in mean.items():
        print(f"  {k:10s} {v:.3f} s  ({100 * v / tot:4.1f} %)")
    print(f"evaluation throughput: {steps / mean['evaluate'] / 1e6:.2f} M robot-steps/s")
    print(f"speed-up over the original C# (12 s/generation): {12.0 / tot:.1f}x")


if __name__ == "__main__":
    main()
