"""A/B of the relaxation CPPN decode (`--cppn-activation relax`) against a named commit, in one run.

The population comes from a run's checkpoint (evolved, cyclic CPPNs: the expensive case) or, without one, from
random recurrent genomes.  Both sides relax the same plans on the situational substrate's queries; the script
checks that their outputs are bit for bit equal and prints the fastest of several interleaved repeats.

    python benchmarks/bench_relax_decode.py [--rev 92b48c1] [--checkpoint RUN/checkpoint.json] [--repeats 3]

It also times the whole population in one `relax_population` call (genomes spread over the cores: wall seconds at
1 thread and at all threads, bit-checked against the plan-by-plan outputs).
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import numba  # noqa: E402

from mahn_evo.cppn.relax import _relax, compile_relax, relax_population  # noqa: E402
from mahn_evo.hyperneat.substrate import query_layout  # noqa: E402


def _old_relax(rev: str):
    """The `_relax` kernel of commit `rev`, imported from its source."""
    src = subprocess.run(["git", "-C", ROOT, "show", f"{rev}:mahn_evo/cppn/relax.py"], check=True,
                         capture_output=True, text=True).stdout
    src = src.replace("from .activations import", "from mahn_evo.cppn.activations import")
    path = os.path.join(tempfile.mkdtemp(), "relax_old.py")
    with open(path, "w") as f:
        f.write(src)
    spec = importlib.util.spec_from_file_location("relax_old", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["relax_old"] = mod
    spec.loader.exec_module(mod)
    return mod._relax


def _genomes(checkpoint: str | None):
    if checkpoint:
        from mahn_evo.neat.population import Population
        with open(checkpoint) as f:
            return Population.from_dict(json.load(f)["population"]).genomes
    sys.path.insert(0, os.path.join(ROOT))
    from tests.evo.helpers import random_genome
    return [random_genome(s, steps=60, kind="iros2011") for s in range(200)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rev", default="92b48c1", help="commit to compare against (default: before the lanes)")
    ap.add_argument("--checkpoint", help="a run's checkpoint.json whose population is decoded")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    plans = [compile_relax(g) for g in _genomes(args.checkpoint)]
    q = np.ascontiguousarray(query_layout("situational", 3).queries, dtype=np.float32)
    sides = {args.rev: _old_relax(args.rev), "now": _relax}

    def run(fn):
        return [fn(q, p.n_inputs, p.act, p.src, p.dst, p.weight, p.mod_ptr, p.mod_in, p.mod_out, p.output_idx,
                   p.steps) for p in plans]

    outs = {k: run(fn) for k, fn in sides.items()}  # also compiles both
    same = all(np.array_equal(a.view(np.uint32), b.view(np.uint32)) for a, b in zip(*outs.values()))
    best = {k: float("inf") for k in sides}
    for _ in range(args.repeats):
        for k, fn in sides.items():
            t = time.process_time()
            run(fn)
            best[k] = min(best[k], time.process_time() - t)
    print(f"{len(plans)} CPPNs x {q.shape[0]} queries, load average {os.getloadavg()[0]:.1f}, bit-identical: {same}")
    for k, v in best.items():
        print(f"  {k:>10}: {v:.3f} CPU-s")
    print(f"  speed-up: {best[args.rev] / best['now']:.2f}x")
    now = np.stack(outs["now"])
    threads = sorted({1, numba.config.NUMBA_NUM_THREADS})
    wall = {n: float("inf") for n in threads}
    cpu = {n: float("inf") for n in threads}
    for _ in range(args.repeats):
        for n in threads:
            numba.set_num_threads(n)
            t, c = time.perf_counter(), time.process_time()
            pop = relax_population(plans, q)
            wall[n] = min(wall[n], time.perf_counter() - t)
            cpu[n] = min(cpu[n], time.process_time() - c)
            if not np.array_equal(pop.view(np.uint32), now.view(np.uint32)):
                raise SystemExit(f"relax_population at {n} thread(s) differs from the plan-by-plan outputs")
    print("  the population in one call (relax_population, bit-identical to plan by plan): "
          + ", ".join(f"{v:.3f} s ({cpu[n]:.3f} CPU-s) at {n} thread(s)" for n, v in wall.items()))



if __name__ == "__main__":
    main()
