"""A/B throughput of the core and the envs: this checkout against a git revision, in one process.

The revision's `mahn_envs` is unpacked (git archive) and imported as `mahn_envs_ab`; both versions run the same
work, interleaved, several times, and the fastest run of each is compared:

  controllers  whole episodes with controllers in the compiled loop (the trainer's evaluation), a
               population-sized batch: random teams (--teams random) or the published situational champions
               (--teams champions, docs/results/experiment_mahn_0.1/champions, evolved behaviour)
  random       whole episodes of a random team (the core alone: sensing, motion, fitness)
  step         BatchSim.step of 16 episodes tick by tick (the RL vector env's path)
  env          the PettingZoo parallel env, kinematic engine, step by step (users' path)

By default one numba thread and CPU time (time.process_time), so a busy machine slows both sides alike and the
ratio stays meaningful; --threads 2 times wall clock on both cores instead.  Fitness and trajectories of every
episode must agree exactly between the versions (the optimisations are required to be bit-identical).
--noise P runs the core's workloads (controllers, random, step) under noise preset P of the trainer
(mahn_evo.evaluation.task_setup.NOISE_PRESETS: generalization, robot), e.g. to time the robot's sensor model; the
revision must know the preset's fields.
Usage: python benchmarks/bench_ab.py [--rev dafc457] [--batch 500] [--repeats 6] [--threads 1] [--brains 2]
       [--teams random|champions] [--noise none|generalization|robot] [--only controllers random step env]
"""
from __future__ import annotations

import argparse
import glob
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

from mahn_envs import patrol_return_v0 as new_env  # noqa: E402
from mahn_envs.policies.team_controllers import TeamControllers  # noqa: E402

FIELDS = ("w_ih", "w_hh", "w_ho", "b_h", "b_o")


def random_teams(n: int, brains: int, seed: int = 1) -> TeamControllers:
    rng = np.random.default_rng(seed)
    w_ih = rng.normal(0, 1.5, (n, 3, brains, 9, 7))
    if brains == 2:
        w_ih[..., 6] = 0
    return TeamControllers(w_ih, rng.normal(0, 1.5, (n, 3, brains, 9, 9)), rng.normal(0, 1.5, (n, 3, brains, 3, 9)),
                           rng.normal(0, 1.5, (n, 3, brains, 9)), rng.normal(0, 1.5, (n, 3, brains, 3)))


def champion_teams(n: int) -> TeamControllers:
    """The published situational champions, repeated to n teams."""
    from mahn_evo.training.champion import Champion

    published = os.path.join(ROOT, "docs", "results", "experiment_mahn_0.1", "champions")
    paths = sorted(glob.glob(os.path.join(published, "situational_*.json")))
    teams = [Champion.load(p).controllers for p in paths]
    return TeamControllers(*(np.stack([getattr(teams[i % len(teams)], f) for i in range(n)]) for f in FIELDS))


def import_revision(rev: str, into: str):
    """mahn_envs as of `rev`, importable as package mahn_envs_ab (its imports are relative)."""
    data = subprocess.run(["git", "-C", ROOT, "archive", rev, "mahn_envs"], check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(into)
    os.rename(os.path.join(into, "mahn_envs"), os.path.join(into, "mahn_envs_ab"))
    sys.path.insert(0, into)
    return importlib.import_module("mahn_envs_ab")


def task_params(core, fields: dict):
    """The version's TaskParams with `fields` (a noise preset), or an error naming what the version lacks."""
    try:
        return core.TaskParams(**fields)
    except TypeError as e:
        raise SystemExit(f"{core.__name__} cannot take the noise preset's fields {sorted(fields)}: {e}") from None


def workloads(pkg, teams: TeamControllers, batch: int, env_steps: int, fields: dict) -> dict:
    """name -> (run, units per run, unit name, result for the identity check) for one version."""
    core = pkg.core if hasattr(pkg, "core") else importlib.import_module(pkg.__name__ + ".core")
    env_mod = pkg.patrol_return_v0 if hasattr(pkg, "patrol_return_v0") else new_env
    params = task_params(core, fields)
    sim_c = core.BatchSim("plus", batch, params)
    sim_r = core.BatchSim("plus", batch, params)
    sim_s = core.BatchSim("plus", 16, params)
    ticks = sim_c.params.max_cycles
    actions = np.random.default_rng(0).integers(0, 3, (ticks, 16, 3))
    env_actions = np.random.default_rng(1).integers(0, 3, (env_steps, 3))

    def controllers():
        return sim_c.run_controllers(teams, seed=1, record=False).fitness.copy()

    def random():
        return sim_r.run_random(seed=1).fitness.copy()

    def step():
        sim_s.reset(seed=2)
        for a in actions:
            sim_s.step(a, validate=False)
        return sim_s.pose.copy()

    env = env_mod.parallel_env()
    agents = env.possible_agents

    def env_loop():
        env.reset(seed=0)
        poses = []
        for i in range(env_steps):
            if not env.agents:
                env.reset(seed=i)
            obs, *_ = env.step({a: int(env_actions[i, k]) for k, a in enumerate(agents)})
            poses.append(sum(float(np.sum(o)) for o in obs.values()))
        return np.array(poses)

    return {"controllers": (controllers, batch * 3 * ticks, "M robot-steps/s"),
            "random": (random, batch * 3 * ticks, "M robot-steps/s"),
            "step": (step, 16 * 3 * ticks, "M robot-steps/s"),
            "env": (env_loop, env_steps, "k env-steps/s")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rev", default="dafc457")
    ap.add_argument("--batch", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=6)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--brains", type=int, default=2)
    ap.add_argument("--teams", choices=("random", "champions"), default="random")
    ap.add_argument("--env-steps", type=int, default=4000)
    ap.add_argument("--noise", choices=("none", "generalization", "robot"), default="none",
                    help="noise preset of the core's workloads (the env runs noise-free)")
    ap.add_argument("--only", nargs="+", default=["controllers", "random", "step", "env"])
    args = ap.parse_args()
    import numba

    from mahn_evo.evaluation.task_setup import NOISE_PRESETS

    fields = dict(NOISE_PRESETS[args.noise])
    numba.set_num_threads(args.threads)
    clock = time.process_time if args.threads == 1 else time.perf_counter
    teams = random_teams(args.batch, args.brains) if args.teams == "random" else champion_teams(args.batch)
    with tempfile.TemporaryDirectory() as d:
        old_pkg = import_revision(args.rev, d)
        importlib.import_module("mahn_envs_ab.core")
        importlib.import_module("mahn_envs_ab.patrol_return_v0")
        import mahn_envs

        versions = {args.rev: workloads(old_pkg, teams, args.batch, args.env_steps, fields),
                    "checkout": workloads(mahn_envs, teams, args.batch, args.env_steps, fields)}
        what = "CPU s, 1 thread" if args.threads == 1 else f"wall s, {args.threads} threads"
        print(f"{args.rev} against this checkout ({what}, fastest of {args.repeats}); results identical in every "
              f"workload; {args.teams} teams; noise {args.noise}")
        names = list(versions)
        for w in args.only:
            results = {k: versions[k][w][0]() for k in names}  # compile / warm up
            if not np.array_equal(results[args.rev], results["checkout"]):
                raise SystemExit(f"{w}: results differ between the two versions")
            times = {k: [] for k in names}
            for i in range(args.repeats):
                for k in (names if i % 2 == 0 else names[::-1]):
                    t = clock()
                    versions[k][w][0]()
                    times[k].append(clock() - t)
            units, unit = versions["checkout"][w][1], versions["checkout"][w][2]
            scale = 1e6 if unit.startswith("M") else 1e3
            rates = {k: units / min(times[k]) / scale for k in names}
            spread = {k: f"{units / max(times[k]) / scale:.2f}-{rates[k]:.2f}" for k in names}
            ratio = rates["checkout"] / rates[args.rev]
            print(f"  {w:12s} {args.rev}: {rates[args.rev]:7.2f} [{spread[args.rev]}]  checkout: "
                  f"{rates['checkout']:7.2f} [{spread['checkout']}] {unit}   ratio {ratio:.2f}x", flush=True)


if __name__ == "__main__":
    main()
