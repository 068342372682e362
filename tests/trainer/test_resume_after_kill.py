"""A run killed with SIGKILL mid-generation resumes bit-identically from its last checkpoint."""
import csv
import json
import os
import signal
import subprocess
import sys
import time

import pytest

from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer

# A generation of this size takes about 10 ms, so the run is made long (about 2 s) and the poll fast: the kill
# must land well before the last generation even on a loaded machine.
GENERATIONS = 200
ARGS = ["--generations", str(GENERATIONS), "--pop", "30", "--seed", "5", "--quiet"]


def _rows(path):
    with open(path / "log.csv") as f:
        return [{k: v for k, v in r.items() if k != "seconds"} for r in csv.DictReader(f)]


@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL")
def test_kill_then_resume_matches_uninterrupted_run(tmp_path):
    cli = [sys.executable, "-m", "mahn_evo.cli", "train"]
    subprocess.run(cli + ARGS + ["--out", str(tmp_path / "full")], check=True, capture_output=True, timeout=300)
    proc = subprocess.Popen(cli + ARGS + ["--out", str(tmp_path / "killed")], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    ckpt = tmp_path / "killed" / "checkpoint.json"
    deadline = time.time() + 240
    while time.time() < deadline:
        if ckpt.exists():
            try:
                if json.loads(ckpt.read_text())["population"]["generation"] >= 3:
                    break
            except (json.JSONDecodeError, KeyError):
                pass  # never happens with atomic writes, but do not fail the test on a race here
        time.sleep(0.005)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    done = json.loads(ckpt.read_text())["population"]["generation"]
    assert 3 <= done < GENERATIONS, "the kill should land mid-run"
    subprocess.run(cli + ARGS + ["--out", str(tmp_path / "killed"), "--resume"], check=True, capture_output=True,
                   timeout=300)
    assert _rows(tmp_path / "killed") == _rows(tmp_path / "full")
    a = json.loads((tmp_path / "full" / "summary.json").read_text())
    b = json.loads((tmp_path / "killed" / "summary.json").read_text())
    assert a["best_fitness"] == b["best_fitness"]


def test_archive_keeps_improving_solutions(tmp_path, monkeypatch):
    """Solved teams are archived when they beat the last archived one (fitness > 100 marks them solved)."""
    tr = Trainer(EvolutionConfig(generations=4, seed=0).with_overrides(pop=20), tmp_path)
    real_outcomes = tr.evaluator.outcomes
    schedule = iter([105.0, 104.0, 110.0, 110.0])

    def fake_outcomes(controllers, generation=0):
        fit, solved, ends = real_outcomes(controllers, generation)
        top = next(schedule)
        fit = fit.copy()
        fit[3] = top
        solved = solved.copy()
        solved[3] = 1.0
        return fit, solved, ends

    monkeypatch.setattr(tr.evaluator, "outcomes", fake_outcomes)
    summary = tr.run()
    archived = sorted(p.name for p in (tmp_path / "archive").iterdir())
    assert archived == ["solution_g00000_i0003.json", "solution_g00002_i0003.json"]
    assert summary["first_solved_generation"] == 0 and summary["solved"]
