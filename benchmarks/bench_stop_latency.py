"""Time from a fault to every robot stopped, on the emulator in real time: this checkout against a git revision.

Three robots drive (real-time emulator on loopback; by default deploy's 0.12 s timeout and 3 attempts), then one
fault is injected just before a step:
  silent  - robot_1 stops answering for good (a dead robot or a dead line);
  delayed - robot_1 answers its next two D commands 2 s late each (a congested radio link);
  frozen  - no robot answers (a frozen bridge).
A watcher thread polls the emulated robots every 2 ms, so "stopped" means the robot really stands still, not that
a reply was counted.  Printed, in seconds: detect = fault to the error surfacing (the retry policy: timeout x
attempts), then from detection: each robot actually stopped, the stop report written (stop_all returned) and,
for robot_1, the moment the report first said it was stopped (``false`` when that was before it really was).
Both versions run in one process (the revision is imported from ``git archive`` as ``mahn_envs_ab``).
Usage: python benchmarks/bench_stop_latency.py [--rev dafc457] [--repeats 3] [--timeout 0.12] [--attempts 3]
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
import threading
import time
import warnings

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

SCENARIOS = ("silent", "delayed", "frozen")


def import_hardware(rev: str, into: str):
    """mahn_envs.hardware as of `rev`, importable as package mahn_envs_ab (its imports are relative)."""
    data = subprocess.run(["git", "-C", ROOT, "archive", rev, "mahn_envs"], check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(into)
    os.rename(os.path.join(into, "mahn_envs"), os.path.join(into, "mahn_envs_ab"))
    sys.path.insert(0, into)
    return importlib.import_module("mahn_envs_ab.hardware")


def make_env(hw, emu, clock, retry):
    """The env on `emu`'s robots through the constructor of `hw`'s version (settings records since they exist,
    flat keywords before)."""
    if hasattr(hw, "Link"):
        return hw.KheperaHardwareEnv(emu.ports, timing=hw.Timing(clock=clock),
                                     poses=hw.Poses(placement=emu.place, pose_source=emu.poses),
                                     link=hw.Link(retry=retry), catch_sigterm=False)
    return hw.KheperaHardwareEnv(emu.ports, clock=clock, placement=emu.place, pose_source=emu.poses,
                                 catch_sigterm=False, retry=retry)


def warm_up(hw) -> None:
    """Compile the numba code of the emulator's motion and sensing and of the env's scoring, untimed."""
    clock = hw.RealClock()
    with hw.KheperaEmulator(3, clock=clock, noise=0.0) as emu, \
            make_env(hw, emu, clock, hw.RetryPolicy(timeout=10.0)) as env:
        env.reset()
        for _ in range(3):
            env.step({a: 1 for a in env.agents})


def run_once(hw, scenario: str, timeout: float, attempts: int) -> dict:
    clock = hw.RealClock()
    emu = hw.KheperaEmulator(3, clock=clock, noise=0.0).start()
    env = make_env(hw, emu, clock, hw.RetryPolicy(timeout=timeout, attempts=attempts))
    marks: dict = {}
    inner = env.stop_all

    def timed_stop_all(*args, **kwargs):
        marks.setdefault("detect", time.monotonic())
        try:
            return inner(*args, **kwargs)
        finally:
            marks.setdefault("report", time.monotonic())

    env.stop_all = timed_stop_all
    stopped: dict = {}
    reported: dict = {}
    done = threading.Event()

    def watch():
        while not done.is_set():
            now = time.monotonic()
            for k in range(3):
                if k not in stopped and emu.world.stopped(k):
                    stopped[k] = now
            if "report" in marks and env.last_stop_report.get("robot_1", "x") is None and "robot_1" not in reported:
                reported["robot_1"] = now
            time.sleep(0.002)

    try:
        env.reset()
        for _ in range(5):
            env.step({a: 1 for a in env.agents})
        if scenario == "silent":
            emu.inject(1, "drop", count=None)
        elif scenario == "delayed":
            emu.inject(1, "delay", count=2, letters="D", delay=2.0)
        else:
            for k in range(3):
                emu.inject(k, "drop", count=None)
        watcher = threading.Thread(target=watch, daemon=True)
        t_fault = time.monotonic()
        watcher.start()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                while env.agents:
                    env.step({a: 1 for a in env.agents})
            except hw.HardwareError:
                pass
        time.sleep(5.0 if scenario == "delayed" else 0.5)  # let late stops land
        done.set()
        watcher.join()
    finally:
        done.set()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env.close()
            if hasattr(env, "give_up_stops"):
                env.give_up_stops()
        emu.stop()
    detect = marks["detect"]
    out = {"detect": detect - t_fault, "report": marks["report"] - detect}
    for k in range(3):
        out[f"robot_{k}"] = stopped[k] - detect if k in stopped else float("nan")
    if "robot_1" in reported:
        out["robot_1 reported"] = reported["robot_1"] - detect
        out["false"] = reported["robot_1"] < stopped.get(1, float("inf"))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rev", default="dafc457")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--timeout", type=float, default=0.12, help="seconds per attempt (deploy's default 0.12)")
    ap.add_argument("--attempts", type=int, default=3, help="attempts per command (deploy's default 3)")
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS), choices=SCENARIOS)
    args = ap.parse_args()
    import mahn_envs.hardware as new_hw

    with tempfile.TemporaryDirectory() as d:
        versions = {args.rev: import_hardware(args.rev, d), "checkout": new_hw}
        for hw in versions.values():
            warm_up(hw)
        for scenario in args.scenarios:
            print(f"{scenario}: seconds, median of {args.repeats} (max); {args.timeout:g} s x {args.attempts} attempts")
            results = {name: [run_once(hw, scenario, args.timeout, args.attempts) for _ in range(args.repeats)]
                       for name, hw in versions.items()}
            for name, runs in results.items():
                keys = [k for k in runs[0] if k != "false"]
                cells = []
                for key in keys:
                    vals = np.array([r.get(key, np.nan) for r in runs], dtype=float)
                    cells.append(f"{key} {np.nanmedian(vals):.3f} ({np.nanmax(vals):.3f})" if np.isfinite(vals).any()
                                 else f"{key} never")
                false = sum(bool(r.get("false")) for r in runs)
                print(f"  {name:10s} " + ", ".join(cells) + (f"; FALSE stop report in {false}/{len(runs)}"
                                                             if false else ""))
            ratio = (np.median([r["report"] for r in results[args.rev]])
                     / np.median([r["report"] for r in results["checkout"]]))
            print(f"  detection to stop report written: {args.rev} / checkout = {ratio:.2f}")


if __name__ == "__main__":
    main()
