"""A/B timing of the controllers-in-the-loop kernel: this checkout against a git revision, in one process.

Both versions run the same population-sized batch of random teams, interleaved, several times; the minimum
of each is compared.  By default one numba thread and CPU time (time.process_time), so a busy machine slows
both sides alike and the ratio stays meaningful; --threads 2 times wall clock on both cores instead.  The
fitness of every team must agree exactly (the optimisations are required to be bit-identical).
Usage: python benchmarks/bench_ab.py [--rev HEAD~1] [--batch 500] [--repeats 6] [--threads 1] [--brains 2]
"""
from __future__ import annotations

import argparse
import importlib
import io
import os
import subprocess
import sys
import tarfile
import tempfile
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

from mahn_envs import core as new_core  # noqa: E402
from mahn_envs.controllers import TeamControllers  # noqa: E402


def random_teams(n: int, brains: int, seed: int = 1) -> TeamControllers:
    rng = np.random.default_rng(seed)
    w_ih = rng.normal(0, 1.5, (n, 3, brains, 9, 7))
    if brains == 2:
        w_ih[..., 6] = 0
    return TeamControllers(w_ih, rng.normal(0, 1.5, (n, 3, brains, 9, 9)), rng.normal(0, 1.5, (n, 3, brains, 3, 9)),
                           rng.normal(0, 1.5, (n, 3, brains, 9)), rng.normal(0, 1.5, (n, 3, brains, 3)))


def import_revision(rev: str, into: str):
    """mahn_envs as of `rev`, importable as package mahn_envs_ab (its imports are relative)."""
    data = subprocess.run(["git", "-C", ROOT, "archive", rev, "mahn_envs"], check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(into)
    os.rename(os.path.join(into, "mahn_envs"), os.path.join(into, "mahn_envs_ab"))
    sys.path.insert(0, into)
    return importlib.import_module("mahn_envs_ab.core")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rev", default="HEAD~1")
    ap.add_argument("--batch", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=6)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--brains", type=int, default=2)
    args = ap.parse_args()
    import numba

    numba.set_num_threads(args.threads)
    clock = time.process_time if args.threads == 1 else time.perf_counter
    teams = random_teams(args.batch, args.brains)
    with tempfile.TemporaryDirectory() as d:
        old_core = import_revision(args.rev, d)
        sims = {args.rev: old_core.BatchSim("plus", args.batch), "checkout": new_core.BatchSim("plus", args.batch)}
        fits = {k: s.run_controllers(teams, seed=1).fitness.copy() for k, s in sims.items()}  # compile / warm up
        if not np.array_equal(fits[args.rev], fits["checkout"]):
            raise SystemExit("fitness differs between the two versions")
        times = {k: [] for k in sims}
        names = list(sims)
        for i in range(args.repeats):
            for k in (names if i % 2 == 0 else names[::-1]):
                t = clock()
                sims[k].run_controllers(teams, seed=1)
                times[k].append(clock() - t)
    what = "CPU s, 1 thread" if args.threads == 1 else f"wall s, {args.threads} threads"
    ticks = new_core.TaskParams().max_cycles
    print(f"{args.batch} episodes x 3 robots x {ticks} ticks, {args.brains} brains ({what}); fitness identical")
    for k in names:
        print(f"  {k:12s} min {min(times[k]):.4f}  median {np.median(times[k]):.4f}")
    print(f"ratio checkout / {args.rev} (min): {min(times['checkout']) / min(times[args.rev]):.3f}")


if __name__ == "__main__":
    main()
