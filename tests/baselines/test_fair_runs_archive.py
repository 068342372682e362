"""docs/results/baselines/fair_runs/archive.py keeps a finished lean PPO run (what `compare --rl-runs` reads, no
checkpoint) and refuses an unfinished or incomplete one, so a partial run is never published as finished."""
from __future__ import annotations

import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

from baselines.comparison.compare import rl_curve, sampled_curve  # noqa: E402
from baselines.lean.config import LeanConfig  # noqa: E402
from baselines.lean.ppo import train  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def archive(tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location(
        "fair_runs_archive", ROOT / "docs" / "results" / "baselines" / "fair_runs" / "archive.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "HERE", tmp_path / "kept")
    (tmp_path / "kept").mkdir()
    return module


def test_a_finished_lean_run_is_kept_and_an_unfinished_one_refused(archive, tmp_path):
    cfg = LeanConfig(method="ppo_ff", seed=3, max_cycles=60, signal_tick=30, n_episodes=2, hidden=8,
                     eval_maps=["plus"], steps=2 * 360)
    run = tmp_path / "runs" / "ppo_ff_seed3"
    train(cfg, run)
    row = archive.keep(run, "abc1234")
    kept = tmp_path / "kept" / "ppo_ff_seed3"
    assert sorted(p.name for p in kept.iterdir()) == sorted(archive.LEAN_FILES)  # no checkpoint
    assert "--method ppo_ff --steps 720 --seed 3" in row and "tune_ppo_ff/best.json" in row and "720 robot-steps" in row
    assert archive._steps(200_000_000) == "2e8" and archive._steps(100_000_000) == "1e8"
    kept_curve, run_curve = rl_curve(kept), rl_curve(run)  # the comparison reads the kept folder as the run
    assert (kept_curve.method, kept_curve.seed) == ("ppo_ff", 3)
    for field in ("budget", "fitness", "solved", "cpu"):
        np.testing.assert_array_equal(getattr(kept_curve, field), getattr(run_curve, field))
    kept_sampled, run_sampled = sampled_curve(kept), sampled_curve(run)  # and its sampling policy
    assert kept_sampled is not None and run_sampled is not None and kept_sampled.method == "ppo_ff_sampled"
    for field in ("budget", "fitness", "solved", "cpu"):
        np.testing.assert_array_equal(getattr(kept_sampled, field), getattr(run_sampled, field))
    best = json.loads((run / "summary.json").read_text())["best_sampled"]
    assert best["fitness_mean"] == pytest.approx(run_sampled.fitness[-1]) and "sampling policy: best mean" in row
    assert "on 20 fresh episodes plus " in row
    # a run whose budget was raised and not yet reached is not finished
    config = json.loads((run / "config.json").read_text())
    (run / "config.json").write_text(json.dumps({**config, "steps": 10 * 360}))
    with pytest.raises(SystemExit, match="720 of 3600 robot-steps: not finished"):
        archive.keep(run, "abc1234")
    (run / "config.json").write_text(json.dumps(config))
    (run / "best_actor.npz").unlink()
    with pytest.raises(SystemExit, match="missing best_actor.npz"):
        archive.keep(run, "abc1234")
    shutil.rmtree(run)
    with pytest.raises(SystemExit, match="not a run folder"):
        archive.keep(run, "abc1234")
