"""Workers of `mahn-evo experiment` die with it, even when it is killed by SIGKILL, and an experiment refuses to
run beside live processes that hold its folders (the lock file names their pid)."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mahn_evo.experiment import ExperimentPlan, run_experiment

SMALL = dict(modes=("situational",), runs=2, seed=5, generations=3, population=16, max_cycles=240, signal_tick=120,
             general_episodes=3, transfer_episodes=1, top=1, replays=0)


def _alive(pid: int) -> bool:
    """Running (a zombie waiting for its reaper has stopped writing: it counts as dead)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def _workers(parent: int) -> list[int]:
    """Pool workers of `parent` (multiprocessing spawn children; not its resource tracker)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            cmd = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        if int(stat.rsplit(")", 1)[1].split()[1]) == parent and "spawn_main" in cmd and "resource_tracker" not in cmd:
            found.append(int(entry.name))
    return found


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigkill_of_the_experiment_ends_its_workers(tmp_path):
    out = tmp_path / "exp"
    cmd = [sys.executable, "-m", "mahn_evo.cli", "experiment", "--modes", "situational", "--runs", "2", "--seed", "5",
           "--generations", "400", "--pop", "16", "--max-cycles", "240", "--signal-tick", "120", "--workers", "2",
           "--no-analysis", "--out", str(out)]
    parent = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              env={**os.environ, "PYTHONPATH": os.getcwd()})
    try:
        deadline = time.time() + 120
        while time.time() < deadline and len(list(out.glob("runs/*/checkpoint.json"))) < 2:
            time.sleep(0.1)
        assert len(list(out.glob("runs/*/checkpoint.json"))) == 2, "both runs should be under way"
        workers = _workers(parent.pid)
        assert len(workers) == 2
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait()
    deadline = time.time() + 10
    while time.time() < deadline and any(_alive(w) for w in workers):
        time.sleep(0.1)
    survivors = [w for w in workers if _alive(w)]
    for w in survivors:  # do not leave them running whatever the outcome
        os.kill(w, signal.SIGKILL)
    assert not survivors, "workers outlived the killed experiment"


_HOLD = ("import sys, time; from mahn_evo.storage.folder_lock import folder_lock\n"
         "with folder_lock(sys.argv[1], 'run folder'):\n    print('held', flush=True); time.sleep(60)")


@pytest.mark.parametrize("held", ["runs/situational_s006", "."])
def test_an_experiment_refuses_to_run_beside_live_holders_of_its_folders(tmp_path, held):
    out = tmp_path / "exp"
    plan = ExperimentPlan(**SMALL)
    holder = subprocess.Popen([sys.executable, "-c", _HOLD, str(out / held)], stdout=subprocess.PIPE, text=True,
                              env={**os.environ, "PYTHONPATH": os.getcwd()})
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(ValueError, match=f"in use by .*process {holder.pid}"):
            run_experiment(plan, out, workers=1, analyse=False, log=lambda m: None)
        assert not (out / "runs" / "situational_s005" / "log.csv").exists()  # nothing started
    finally:
        holder.kill()
        holder.wait()
    # the holder is dead: its lock is taken over and the experiment runs
    run_experiment(plan, out, workers=1, analyse=False, log=lambda m: None)
    assert all((out / "runs" / f"situational_s00{s}" / "summary.json").exists() for s in (5, 6))
    assert not list(out.rglob(".mahn.lock"))


def test_map_in_processes_keeps_the_items_order_and_uses_other_processes():
    from operator import mul

    from mahn_evo.experiment.backends import map_in_processes

    assert map_in_processes(mul, [(2, 3), (4, 5), (6, 7)], workers=2) == [6, 20, 42]
    assert map_in_processes(mul, [(2, 3), (4, 5)], workers=1) == [6, 20]
    pids = map_in_processes(os.getpid, [(), ()], workers=2)
    assert os.getpid() not in pids
