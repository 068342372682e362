"""Training throughput of the lean PPO methods (whole updates: rollout + PPO epochs) against the issue's targets,
and against SB3's PPO / RecurrentPPO as configured in `baselines/sb3/algos.py`, measured in the same run.

Robot-steps/s are given per wall second and per CPU second of this process (`time.process_time`): on a
shared machine the wall figure depends on the other load, the CPU figure much less.  torch runs on 1 thread.

With `--rev REV [REV ...]` the lean methods of each revision (its `baselines`, `mahn_envs` and `mahn_evo`, unpacked
with git archive) are measured beside this checkout's in one run, in worker processes that alternate between the
versions (A B B A ...), and the ratio of the fastest worker of each is printed (the machine is shared).

    python benchmarks/bench_rl.py [--methods ppo_ff ippo_gru mappo_gru] [--episodes 32] [--updates 1]
                                  [--sb3-steps 49152]   # 0 skips SB3
    python benchmarks/bench_rl.py --rev e2a4a3c [--repeats 2] [--methods ...] [--updates 2] [--tuned DIR]
"""
from __future__ import annotations

import argparse
import io
import json
import os
import subprocess
import sys
import tarfile
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, ROOT)  # this checkout's code

# A worker: the lean methods of the code in folder argv[1] (first on sys.path), as `bench_lean` measures them.
WORKER = r"""
import json, os, sys, tempfile, time
code = sys.argv[1]
sys.path.insert(0, code)
if os.path.isdir(os.path.join(code, "baselines", "lean")):
    from baselines.lean.config import LeanConfig
    from baselines.lean.ppo import LeanPPO
else:  # a revision before baselines/ had a folder per concept (chosen by its files: an editable install of
    # this checkout would otherwise serve the new layout's modules to the old package)
    from baselines.lean_config import LeanConfig
    from baselines.lean_ppo import LeanPPO
loaded = [m.__file__ for n, m in list(sys.modules.items())
          if n.split(".")[0] in ("baselines", "mahn_envs", "mahn_evo") and getattr(m, "__file__", None)]
assert all(f.startswith(code) for f in loaded), [f for f in loaded if not f.startswith(code)]
out = {}
settings = json.loads(sys.argv[4])
for m in sys.argv[5:]:
    with tempfile.TemporaryDirectory() as d:
        run = LeanPPO(LeanConfig(method=m, steps=10**12, eval_maps=["plus"],
                                 **{"n_episodes": int(sys.argv[2]), **settings.get(m, {})}), os.path.join(d, "run"))
        run.learn(run.rollout())
        c0 = time.process_time()
        for _ in range(int(sys.argv[3])):
            run.learn(run.rollout())
        out[m] = int(sys.argv[3]) * run.steps_per_update / (time.process_time() - c0)
print(json.dumps(out))
"""

TARGETS = {"ppo_ff": 60_000, "ippo_gru": 20_000, "mappo_gru": 20_000}


def tuned_settings(folder: str | None, method: str) -> dict:
    """The tuned settings of a method (FOLDER/tune_<method>/best.json, as `mahn-baselines tune` writes them), or
    {} (the defaults) without a folder or a finished study there."""
    path = os.path.join(folder, f"tune_{method}", "best.json") if folder else None
    if path is None or not os.path.isfile(path):
        return {}
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def bench_lean(method: str, episodes: int, updates: int, settings: dict | None = None) -> tuple[float, float]:
    """(robot-steps per second, per CPU-second) of `updates` updates after a warm-up one; `settings` override the
    defaults (a tuned best.json: its own episodes per update then replace `episodes`)."""
    from baselines.lean.config import LeanConfig
    from baselines.lean.ppo import LeanPPO

    with tempfile.TemporaryDirectory() as out:
        cfg = LeanConfig(method=method, steps=10**12, eval_maps=["plus"],
                         **{"n_episodes": episodes, **(settings or {})})
        run = LeanPPO(cfg, os.path.join(out, "run"))
        run.learn(run.rollout())  # warm-up: first calls allocate and initialise
        c0, t0 = time.process_time(), time.perf_counter()
        for _ in range(updates):
            run.learn(run.rollout())
        n = updates * run.steps_per_update
        return n / (time.perf_counter() - t0), n / (time.process_time() - c0)


def bench_sb3(algo: str, steps: int) -> tuple[float, float]:
    import torch

    from baselines.sb3.algos import get_algo, resolved_hyperparams
    from baselines.vec_env import PatrolReturnVecEnv, register_with_sb3

    register_with_sb3()
    torch.set_num_threads(1)
    spec = get_algo(algo)
    env = PatrolReturnVecEnv(16, reward_scale=0.1)
    model = spec.model_class()(spec.policy, env, seed=0, device="cpu", verbose=0, **resolved_hyperparams(algo))
    c0, t0 = time.process_time(), time.perf_counter()
    model.learn(total_timesteps=steps)
    n = model.num_timesteps
    return n / (time.perf_counter() - t0), n / (time.process_time() - c0)


def unpack_revision(rev: str, into: str) -> str:
    """`baselines`, `mahn_envs` and `mahn_evo` as of `rev`, in folder `into` (returned)."""
    data = subprocess.run(["git", "-C", ROOT, "archive", rev, "baselines", "mahn_envs", "mahn_evo"], check=True,
                          capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(into, filter="data")
    return into


def ab(revs: list[str], methods: list[str], episodes: int, updates: int, repeats: int,
       settings: dict[str, dict] | None = None) -> None:
    """This checkout against each revision, interleaved: robot-steps per CPU-second, the fastest worker each;
    `settings` (method -> settings, e.g. tuned) override the defaults on every side."""
    with tempfile.TemporaryDirectory() as tmp:
        versions = {"this checkout": ROOT}
        versions.update({rev: unpack_revision(rev, os.path.join(tmp, rev)) for rev in revs})
        order = list(versions)
        best: dict[str, dict[str, float]] = {v: {} for v in order}
        for k in range(repeats):
            for v in (order if k % 2 == 0 else order[::-1]):
                res = subprocess.run([sys.executable, "-c", WORKER, versions[v], str(episodes), str(updates),
                                      json.dumps(settings or {}), *methods], check=True, capture_output=True, text=True,
                                     env=dict(os.environ, OMP_NUM_THREADS="1")).stdout
                for m, rate in json.loads(res.splitlines()[-1]).items():
                    best[v][m] = max(best[v].get(m, 0.0), rate)
                print(f"  worker {k + 1}/{repeats} {v}: " + ", ".join(f"{m} {r:,.0f}" for m, r in
                                                                       json.loads(res.splitlines()[-1]).items()),
                      flush=True)
    print(f"{'method':<12}" + "".join(f"{v:>16}" for v in order) + "   (robot-steps per CPU-second, fastest worker)")
    for m in methods:
        print(f"{m:<12}" + "".join(f"{best[v][m]:>16,.0f}" for v in order)
              + "".join(f"   {best[order[0]][m] / best[r][m]:.2f}x vs {r}" for r in order[1:]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--methods", nargs="+", default=list(TARGETS), choices=list(TARGETS))
    ap.add_argument("--episodes", type=int, default=32, help="episodes per rollout (slots = x3)")
    ap.add_argument("--updates", type=int, default=1, help="timed updates per method (after one warm-up)")
    ap.add_argument("--sb3-steps", type=int, default=49152, help="robot-steps of each SB3 reference (0: skip)")
    ap.add_argument("--rev", nargs="+", default=[], help="revisions to measure beside this checkout (lean only)")
    ap.add_argument("--repeats", type=int, default=2, help="with --rev: workers per version")
    ap.add_argument("--tuned", metavar="DIR",
                    help="measure each method with its tuned settings, DIR/tune_<method>/best.json (e.g. "
                         "docs/results/baselines/fair_runs), where the study has finished; the defaults otherwise")
    a = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    if a.rev:
        tuned = {m: tuned_settings(a.tuned, m) for m in a.methods}
        print("settings: " + ", ".join(f"{m} {'tuned ' + json.dumps(s) if s else 'defaults'}"
                                       for m, s in tuned.items()))
        ab(a.rev, a.methods, a.episodes, a.updates, a.repeats, tuned)
        print(f"load average after: {os.getloadavg()[0]:.2f}")
        return
    print(f"{'method':<16}{'robot-steps/s':>15}{'per CPU-s':>12}{'target':>9}  meets (CPU-s)  settings")
    lean = {}
    for m in a.methods:
        settings = tuned_settings(a.tuned, m)
        wall, cpu = bench_lean(m, a.episodes, a.updates, settings)
        lean[m] = cpu
        print(f"{m:<16}{wall:>15,.0f}{cpu:>12,.0f}{TARGETS[m]:>9,}  {'yes' if cpu >= TARGETS[m] else 'NO':<13}  "
              f"{'tuned' if settings else 'defaults'}", flush=True)
    if a.sb3_steps > 0:
        refs = {"ppo": "ppo_ff", "recurrent_ppo": "ippo_gru"}
        for algo, ours in refs.items():
            wall, cpu = bench_sb3(algo, a.sb3_steps)
            ratio = f"{ours} / {algo} = {lean[ours] / cpu:.1f}x (CPU-s)" if ours in lean else ""
            print(f"sb3 {algo:<12}{wall:>15,.0f}{cpu:>12,.0f}{'':>9}  {ratio}", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
