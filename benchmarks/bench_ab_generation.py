"""A/B seconds per training generation: this checkout against a git revision, interleaved, in one run.

The revision's `mahn_envs` and `mahn_evo` are unpacked (git archive) into a temporary folder, and every module a
worker loads must come from its version's folder (an editable install would otherwise fill modules an old layout
lacks with this checkout's).  Each version trains its own run folder (the same generations from the same seed,
since an old revision cannot read a newer format) up to --skip generations, so the timed generations are evolved,
not random, teams.  Then worker processes alternate between the versions (A B B A ...): each resumes a copy of its
version's run folder and, after one untimed generation, times --generations generations split into decode (NEAT
ask + CPPN decoding), evaluate, reproduce (NEAT tell) and checkpoint, exactly as the trainer runs them.  Every
worker must produce the same fitness values (the optimisations are required to be bit-identical); the comparison
uses each version's fastest worker and prints the spread over workers, since the machine is shared.
NUMBA_NUM_THREADS sets the cores of each worker.

Several revisions (--rev dafc457 5c94b5e) are measured in the same interleaved run, each beside the checkout.
--run DIR times the generations after an existing run folder's checkpoint instead (e.g. generation 1000 of a
paper-scale run, whose grown CPPNs cost more to decode than the early ones; the folder is copied, never changed).

Usage: python benchmarks/bench_ab_generation.py [--rev dafc457 [REV ...]] [--pop 500 2000] [--threads 1 2]
       [--repeats 3] [--generations 4] [--skip 20] [--init iros2011] [--episodes 1] [--noise none|generalization]
       [--run DIR]
"""
from __future__ import annotations

import argparse
import io
import json
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

# The start of both worker scripts: the version's own modules (folder `code`), whatever the layout of its time.
PRELUDE = r"""
import hashlib, importlib, json, os, shutil, sys, tempfile, time
code = sys.argv[1]
# An editable install's finder would fill modules missing from the revision with this checkout's: drop it, so
# every module comes from `code` (checked below).
sys.meta_path = [f for f in sys.meta_path if "editable" not in getattr(f, "__name__", type(f).__name__).lower()]
sys.path.insert(0, code)
import numpy as np
import mahn_evo
assert mahn_evo.__file__.startswith(code), (mahn_evo.__file__, code)


def first(*names):
    # the first of the module:attribute names that this version has
    for name in names:
        module, attr = name.split(":")
        if os.path.exists(os.path.join(code, *module.split("."))) or \
                os.path.exists(os.path.join(code, *module.split(".")) + ".py"):
            mod = importlib.import_module(module)
            if hasattr(mod, attr):
                return getattr(mod, attr)
    raise SystemExit(f"none of {names} in {code}")


Config = first("mahn_evo.training.config:EvolutionConfig", "mahn_evo.config:EvolutionConfig",
               "mahn_evo.config:TrainConfig")
read_versioned_json = first("mahn_evo.storage.files:read_versioned_json", "mahn_evo.files:read_versioned_json")
Trainer = first("mahn_evo.training.trainer:Trainer", "mahn_evo.trainer:Trainer")
task_params = first("mahn_evo.evaluation.task_setup:task_params", "mahn_evo.task_setup:task_params",
                    "mahn_evo.evaluate:task_params")
loaded = [m.__file__ for name, m in list(sys.modules.items())
          if name.split(".")[0] in ("mahn_evo", "mahn_envs") and getattr(m, "__file__", None)]
assert all(f.startswith(code) for f in loaded), [f for f in loaded if not f.startswith(code)]
"""

# Trains the starting run folder with the version's own code (an old revision cannot read a newer run folder).
MAKE_RUN = PRELUDE + r"""
folder, pop, skip, init, episodes, noise = sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5], \
    int(sys.argv[6]), sys.argv[7]
cfg = Config(init=init, episodes=episodes, generations=max(skip, 1), task=task_params(noise)).with_overrides(pop=pop)
tr = Trainer(cfg, folder)
for _ in range(skip):
    tr.step()
tr._write_log()
tr._checkpoint()
"""

# Runs inside a worker process, with the version's folder first on sys.path.
WORKER = PRELUDE + r"""
run_dir, n_gen = sys.argv[2], int(sys.argv[3])
EvolutionConfig = Config
with tempfile.TemporaryDirectory() as d:
    shutil.copytree(run_dir, d, dirs_exist_ok=True)
    cfg = EvolutionConfig.from_saved(read_versioned_json(f"{d}/config.json", "config"))
    tr = Trainer(cfg.with_overrides(generations=10**6), d, resume=True)
    def evaluator():
        # the evaluator the trainer's step uses for this generation: with robust_from "first_solution", the
        # noise-free one until the robust phase starts (revisions that have it)
        nf = getattr(tr, "noise_free_evaluator", None)
        if nf is not None:
            start = tr.config.robust_phase_start(tr.first_solved)
            if start is None or tr.population.generation < start:
                return nf
        return tr.evaluator
    def score(genomes, controllers):
        # the generation's fitness and solved fractions as the trainer gets them: `evaluate` (with symmetry "best"
        # every mirror reading of each genome is scored, the best counts), after `decode` timed apart (the
        # evaluator's decode memo then hands evaluate the same controllers)
        g = tr.population.generation
        ev_ = evaluator()
        if hasattr(ev_, "evaluate"):
            try:
                ev = ev_.evaluate(genomes, g)
            except TypeError:  # a revision from before per-generation draws
                ev = ev_.evaluate(genomes)
            return ev.fitness, ev.solved
        try:  # a revision whose evaluator only scored controllers
            return tr.evaluator.score(controllers, g)
        except TypeError:
            return tr.evaluator.score(controllers)
    # one untimed generation: loads the compiled code and, as in a running trainer, leaves the previous
    # generation in the evaluator's memos (revisions that have them)
    first = tr.population.ask()
    tr.population.tell(score(first, evaluator().decode(first))[0])
    parts = {"decode": [], "evaluate": [], "reproduce": [], "checkpoint": []}
    cpu = []
    digest = hashlib.sha256()
    for _ in range(n_gen):
        c0 = time.process_time()
        t0 = time.perf_counter()
        genomes = tr.population.ask()
        controllers = evaluator().decode(genomes)
        t1 = time.perf_counter()
        fitness, solved = score(genomes, controllers)
        t2 = time.perf_counter()
        tr.population.tell(fitness)
        t3 = time.perf_counter()
        tr._checkpoint()
        t4 = time.perf_counter()
        cpu.append(time.process_time() - c0)
        for k, v in zip(parts, (t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
            parts[k].append(v)
        digest.update(np.ascontiguousarray(fitness, dtype=np.float64).tobytes())
        digest.update(np.ascontiguousarray(solved, dtype=np.float64).tobytes())
print(json.dumps({"parts": parts, "cpu": cpu, "digest": digest.hexdigest()}))
"""


def unpack_revision(rev: str, into: str) -> str:
    """`mahn_envs` and `mahn_evo` as of `rev`, in folder `into` (returned)."""
    data = subprocess.run(["git", "-C", ROOT, "archive", rev, "mahn_envs", "mahn_evo"], check=True,
                          capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(into)
    return into


def make_run(code: str, folder: str, pop: int, skip: int, init: str, episodes: int, noise: str) -> None:
    """Train `skip` generations with the version in `code` into `folder` (the starting point of its workers;
    every version trains the same generations from the same seed, bit for bit)."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    subprocess.run([sys.executable, "-c", MAKE_RUN, code, folder, str(pop), str(skip), init, str(episodes), noise],
                   env=env, check=True, cwd=code)


def run_population(run: str) -> int:
    """The population size of an existing run folder (its config.json)."""
    with open(os.path.join(run, "config.json")) as f:
        return int(json.load(f)["neat"]["population_size"])


def run_worker(code: str, run_dir: str, generations: int, threads: int) -> dict:
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", WORKER, code, run_dir, str(generations)], env=env,
                         capture_output=True, text=True, cwd=code)
    if out.returncode:
        raise SystemExit(f"the worker of {code} failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def measure(versions: dict[str, str], run_dirs: dict[str, str], generations: int, threads: int,
            repeats: int) -> dict:
    """Per version: seconds per generation of each worker (mean over its generations) and its parts."""
    names = list(versions)
    got: dict[str, list[dict]] = {k: [] for k in names}
    for i in range(repeats):
        for k in (names if i % 2 == 0 else names[::-1]):
            got[k].append(run_worker(versions[k], run_dirs[k], generations, threads))
    digests = {w["digest"] for ws in got.values() for w in ws}
    if len(digests) != 1:
        raise SystemExit(f"fitness differs between versions or workers ({len(digests)} different results)")
    result = {}
    for k, ws in got.items():
        totals = [float(np.mean(np.sum([w["parts"][p] for p in w["parts"]], axis=0))) for w in ws]
        best = int(np.argmin(totals))
        result[k] = {"totals": totals, "cpu": [float(np.mean(w["cpu"])) for w in ws],
                     "parts": {p: float(np.mean(v)) for p, v in ws[best]["parts"].items()}}
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rev", nargs="+", default=["dafc457"])
    ap.add_argument("--pop", type=int, nargs="+", default=[500])
    ap.add_argument("--threads", type=int, nargs="+", default=[2])
    ap.add_argument("--repeats", type=int, default=3, help="workers per version and setting")
    ap.add_argument("--generations", type=int, default=4, help="timed generations per worker")
    ap.add_argument("--skip", type=int, default=20, help="generations trained before timing")
    ap.add_argument("--init", default="iros2011")
    ap.add_argument("--episodes", type=int, default=1)
    ap.add_argument("--noise", default="none", help="task noise preset of mahn_evo.evaluation.task_setup (none, "
                                                     "generalization)")
    ap.add_argument("--run", help="time the generations after this run folder's checkpoint (its own settings; "
                                   "--pop, --skip, --init, --episodes and --noise are not used)")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        versions = {rev: unpack_revision(rev, os.path.join(tmp, f"rev{i}")) for i, rev in enumerate(args.rev)}
        versions["checkout"] = ROOT
        for pop in ([run_population(args.run)] if args.run else args.pop):
            run_dirs = {k: os.path.join(tmp, f"run{pop}_{i}") for i, k in enumerate(versions)}
            for k, run_dir in run_dirs.items():
                if args.run:  # every version resumes the same folder (the versions must read its format)
                    shutil.copytree(args.run, run_dir, ignore=shutil.ignore_patterns(".mahn.lock", "archive",
                                                                                     "*.png"))
                else:
                    make_run(versions[k], run_dir, pop, args.skip, args.init, args.episodes, args.noise)
            for threads in args.threads:
                res = measure(versions, run_dirs, args.generations, threads, args.repeats)
                rows.append((pop, threads, res))
                print_row(args, pop, threads, res)
            for run_dir in run_dirs.values():
                shutil.rmtree(run_dir)
    what = f"run {args.run}" if args.run else f"{args.init}, episodes {args.episodes}, noise {args.noise}"
    print(f"\nsummary ({what}; seconds per generation, fastest "
          f"worker, [spread over {args.repeats} workers]; load average {os.getloadavg()[0]:.1f}):")
    names = args.rev + ["checkout"]
    print(f"{'population':>10} {'threads':>7} " + " ".join(f"{k:>22}" for k in names)
          + " " + " ".join(f"{'vs ' + r:>12}" for r in args.rev))
    for pop, threads, res in rows:
        cells = " ".join(f"{min(res[k]['totals']):8.3f} [{min(res[k]['totals']):.3f}-{max(res[k]['totals']):.3f}]"
                         for k in names)
        ratios = " ".join(f"{min(res[r]['totals']) / min(res['checkout']['totals']):11.2f}x" for r in args.rev)
        print(f"{pop:>10} {threads:>7} {cells} {ratios}")
    print("CPU seconds per generation (all threads; less sensitive to other load than the wall clock above):")
    for pop, threads, res in rows:
        cells = " ".join(f"{min(res[k]['cpu']):8.3f}" for k in names)
        ratios = " ".join(f"{min(res[r]['cpu']) / min(res['checkout']['cpu']):.2f}x vs {r}" for r in args.rev)
        print(f"{pop:>10} {threads:>7} {cells}   {ratios}")


def print_row(args, pop: int, threads: int, res: dict) -> None:
    timed = (f"{args.generations} generations after {args.run}" if args.run
             else f"generations {args.skip}..{args.skip + args.generations - 1}")
    print(f"population {pop}, {threads} thread(s), {timed}, "
          "fitness identical in every worker")
    for k, r in res.items():
        parts = "  ".join(f"{p} {v:.3f}" for p, v in r["parts"].items())
        print(f"  {k:10s} {min(r['totals']):.3f} s/generation ({parts}); workers: "
              + " ".join(f"{t:.3f}" for t in r["totals"]) + f"; CPU s/generation {min(r['cpu']):.3f}")
    print("  speed-up: " + ", ".join(f"{min(res[r]['totals']) / min(res['checkout']['totals']):.2f}x vs {r}"
                                     for r in args.rev) + f" (load average {os.getloadavg()[0]:.1f})", flush=True)


if __name__ == "__main__":
    main()
