"""Seconds to write checkpoint.json at paper scale: this checkout against a git revision, in one run.

A population of 500 (situational, the paper's seed genome) is bred for some generations with random fitness
(no simulation: only the state's size matters), with a log of 1000 rows as at the end of a paper-scale run;
then Trainer._checkpoint is timed (CPU time, steady on a shared machine, and wall time with the fsync),
alternating between this checkout and the revision (each in its own process: the two versions cannot share
one interpreter), and the minimum of each is compared.
Usage: python benchmarks/bench_checkpoint.py [--rev dafc457] [--pop 500] [--generations 30] [--repeats 5]
"""
from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import tarfile
import tempfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

_CHILD = r"""
import sys, tempfile, time
import numpy as np
try:  # the layout since issue 13 (mahn_evo/training/)
    from mahn_evo.training.config import EvolutionConfig
    from mahn_evo.training.trainer import Trainer
except ModuleNotFoundError:  # a revision from before it: the same modules at the top of mahn_evo/
    from mahn_evo.config import EvolutionConfig
    from mahn_evo.trainer import Trainer
pop, gens, reps = map(int, sys.argv[1:4])
cfg = EvolutionConfig(generations=1000).with_overrides(pop=pop)
with tempfile.TemporaryDirectory() as d:
    tr = Trainer(cfg, d)
    rng = np.random.default_rng(0)
    for _ in range(gens):
        tr.population.ask()
        tr.population.tell(rng.random(pop))
    tr.rows = [[g, g * pop, 1.5, 0.5, 1.5, False, 0, 12, 3.0, 40.5, 0.4] for g in range(1000)]
    wall, cpu = [], []
    for _ in range(reps):
        t0, c0 = time.perf_counter(), time.process_time()
        tr._checkpoint()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    import os
    print(min(cpu), min(wall), os.path.getsize(f"{d}/checkpoint.json"))
"""


def _time(tree: str, args) -> tuple[float, float, int]:
    env = {**os.environ, "PYTHONPATH": tree, "NUMBA_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", _CHILD, str(args.pop), str(args.generations), str(args.repeats)],
                         check=True, capture_output=True, text=True, cwd=tree, env=env).stdout.split()
    return float(out[0]), float(out[1]), int(out[2])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rev", default="dafc457")
    ap.add_argument("--pop", type=int, default=500)
    ap.add_argument("--generations", type=int, default=30)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3, help="alternations between the two versions")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as old:
        data = subprocess.run(["git", "-C", ROOT, "archive", args.rev, "mahn_evo", "mahn_envs"], check=True,
                              capture_output=True).stdout
        with tarfile.open(fileobj=io.BytesIO(data)) as tar:
            tar.extractall(old)
        new_t, old_t = [], []
        for _ in range(args.rounds):
            new_t.append(_time(ROOT, args))
            old_t.append(_time(old, args))
    nc, nw, nsize = min(t[0] for t in new_t), min(t[1] for t in new_t), new_t[0][2]
    oc, ow, osize = min(t[0] for t in old_t), min(t[1] for t in old_t), old_t[0][2]
    print(f"checkpoint write, population {args.pop}, {args.generations} generations bred, 1000 log rows "
          "(minimum CPU and wall time; wall includes the fsync)")
    print(f"  {args.rev:>10}: {1000 * oc:6.1f} ms CPU  {1000 * ow:6.1f} ms wall  ({osize / 1e6:.2f} MB)")
    print(f"  {'this':>10}: {1000 * nc:6.1f} ms CPU  {1000 * nw:6.1f} ms wall  ({nsize / 1e6:.2f} MB)   "
          f"ratio CPU {nc / oc:.2f}, wall {nw / ow:.2f}")


if __name__ == "__main__":
    main()
