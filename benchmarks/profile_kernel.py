"""Where the compiled evaluation spends its time: a sampling profile of numba's machine code, by address.

numba's JIT code has no symbols for `perf`, and the episode loop is one inlined function, so a profile by function
says nothing.  This script runs a workload under `perf record -e cpu-clock` (a software clock: it works where the
hardware counters are not available), copies the process's executable anonymous memory (the JIT code) before it
exits, and prints the hottest 1 KB blocks of the compiled code with what their instructions are (counts of gathers,
512-bit operations, double divisions, 64-bit constants as the hash draws load them, calls), beside the shares of
the C libraries (libm: `sincos`).  Reading the blocks as the kernel's parts is the user's step: the network is the
block run of 16-lane float32 arithmetic with the sigmoid's table gathers, the ray casts the run with the 8-lane double
divisions, the decisions and encodings the runs that load the random streams' constants.

Workloads: `controllers` (BatchSim.run_controllers on the published situational champions, as `bench_ab.py
--teams champions`) or `trainer` (the trainer's first G generations, `--init iros2011`, pop 500).
Usage: python benchmarks/profile_kernel.py [--workload controllers|trainer] [--noise generalization] [--episodes 4]
       [--generations 20] [--repeats 8] [--top 25]
Needs Linux `perf` (Debian's linux-perf).  One numba thread.
"""
from __future__ import annotations

import argparse
import collections
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

# Run inside `perf record`: the workload, then a copy of every executable anonymous mapping (the JIT code).
WORKER = r"""
import ctypes, json, os, sys, time
sys.path.insert(0, sys.argv[1])
sys.path.insert(0, os.path.join(sys.argv[1], "benchmarks"))
out, workload, noise, episodes, generations, repeats = sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]), \
    int(sys.argv[6]), int(sys.argv[7])
from mahn_evo.evaluation.task_setup import task_params
if workload == "controllers":
    from bench_ab import champion_teams
    from mahn_envs.core import BatchSim
    teams = champion_teams(500)
    sim = BatchSim("plus", 500, task_params(noise))
    sim.run_controllers(teams, seed=1)
    for s in range(repeats):
        sim.run_controllers(teams, seed=2 + s)
else:
    from mahn_evo.training.config import EvolutionConfig
    from mahn_evo.training.trainer import Trainer
    cfg = EvolutionConfig(init="iros2011", episodes=episodes, generations=generations + 1,
                          task=task_params(noise)).with_overrides(pop=500)
    trainer = Trainer(cfg, os.path.join(out, "run"))
    for g in range(generations):
        trainer.step()
regions = []
with open("/proc/self/maps") as f:
    for line in f:
        parts = line.split()
        if "x" in parts[1] and len(parts) < 6:  # executable, no file behind it
            lo, hi = (int(v, 16) for v in parts[0].split("-"))
            path = os.path.join(out, f"code_{lo:x}.bin")
            with open(path, "wb") as g:
                g.write(bytes((ctypes.c_char * (hi - lo)).from_address(lo)))
            regions.append([lo, hi, path])
with open(os.path.join(out, "regions.json"), "w") as f:
    json.dump(regions, f)
"""

SIGNS = {"gathers": r"gather", "zmm ops": r"zmm", "double divisions": r"vdivpd|vdivsd",
         "float divisions": r"vdivps|vdivss", "64-bit constants": r"movabs", "calls": r"\bcall"}


def disassemble(path: str, base: int) -> list[tuple[int, str]]:
    """(address, instruction) of a raw code dump, by objdump."""
    text = subprocess.run(["objdump", "-D", "-b", "binary", "-m", "i386:x86-64", f"--adjust-vma={base:#x}", path],
                          check=True, capture_output=True, text=True).stdout
    out = []
    for line in text.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*(.*)", line)
        if m:
            out.append((int(m.group(1), 16), m.group(2).strip()))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workload", choices=("controllers", "trainer"), default="trainer")
    ap.add_argument("--noise", default="generalization")
    ap.add_argument("--episodes", type=int, default=4, help="trainer: episodes per team")
    ap.add_argument("--generations", type=int, default=20, help="trainer: generations evaluated")
    ap.add_argument("--repeats", type=int, default=8, help="controllers: timed batches")
    ap.add_argument("--top", type=int, default=25, help="hottest 1 KB blocks to list")
    a = ap.parse_args()
    for tool in ("perf", "objdump"):
        if shutil.which(tool) is None:
            raise SystemExit(f"{tool} not found: install Debian's linux-perf and binutils")
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "perf.data")
        env = dict(os.environ, NUMBA_NUM_THREADS="1")
        subprocess.run(["perf", "record", "-q", "-e", "cpu-clock", "-F", "1000", "-o", data, sys.executable, "-c",
                        WORKER, ROOT, tmp, a.workload, a.noise, str(a.episodes), str(a.generations), str(a.repeats)],
                       check=True, env=env)
        script = subprocess.run(["perf", "script", "-i", data, "-F", "ip,dso"], check=True, capture_output=True,
                                text=True).stdout
        with open(os.path.join(tmp, "regions.json")) as f:
            regions = json.load(f)
        jit: collections.Counter = collections.Counter()
        libs: collections.Counter = collections.Counter()
        for line in script.splitlines():
            parts = line.split()
            if not parts:
                continue
            ip = int(parts[0], 16)
            region = next((r for r in regions if r[0] <= ip < r[1]), None)
            if region is not None:
                jit[(region[0], ip)] += 1
            else:
                libs[os.path.basename(parts[-1].strip("()"))] += 1
        if not jit:
            raise SystemExit("no samples in compiled code: did the workload run?")
        # the region with most samples is the kernel's module
        by_region: collections.Counter = collections.Counter()
        for (lo, _), c in jit.items():
            by_region[lo] += c
        lo = by_region.most_common(1)[0][0]
        path = next(r[2] for r in regions if r[0] == lo)
        code = disassemble(path, lo)
        hist = {ip: c for (base, ip), c in jit.items() if base == lo}
        libm = sum(c for name, c in libs.items() if name.startswith("libm"))
        total = sum(hist.values()) + libm
        blocks: dict[int, dict] = {}
        for ip, ins in code:
            b = blocks.setdefault((ip - lo) // 1024, {"samples": 0, **{k: 0 for k in SIGNS}})
            b["samples"] += hist.get(ip, 0)
            for name, pattern in SIGNS.items():
                b[name] += bool(re.search(pattern, ins))
    print(f"workload {a.workload}, noise {a.noise}: {total} samples in the kernel's compiled code and libm "
          f"({sum(by_region.values()) - by_region[lo]} in other compiled code; {sum(libs.values()) - libm} in "
          "other libraries: Python, numba's compiler, ...)")
    print(f"libm (sincos of the headings, ...): {100 * libm / total:.1f} %")
    print(f"{'block':>8} {'share':>7}  " + "  ".join(f"{k:>16}" for k in SIGNS))
    hot = sorted(blocks.items(), key=lambda kv: -kv[1]["samples"])[:a.top]
    for k, b in sorted(hot):
        print(f"{k:>6}KB {100 * b['samples'] / total:6.1f}%  " + "  ".join(f"{b[n]:>16}" for n in SIGNS))


if __name__ == "__main__":
    main()
