"""The optuna harness: a smoke run, deterministic suggestions, resuming a study and an interrupted trial."""
from __future__ import annotations

import json

import pytest

optuna = pytest.importorskip("optuna")
pytest.importorskip("torch")

from baselines.lean.tune import STUDY_FILE, objective_value, trials_table, tune  # noqa: E402

TINY = {"max_cycles": 60, "signal_tick": 30}


def _params(out):
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    study = optuna.load_study(study_name="lean_ppo_ff",
                              storage=JournalStorage(JournalFileBackend(str(out / STUDY_FILE))))
    return [(t.number, t.state.name, t.params) for t in study.get_trials()]


def test_smoke_run_is_deterministic_and_resumes(tmp_path):
    log = []
    cost = tune("ppo_ff", tmp_path / "a", trials=2, steps=1, base=TINY, log=log.append)
    assert cost["trials_completed"] == 2 and cost["robot_steps"] > 0 and cost["cpu_seconds"] > 0
    assert json.loads((tmp_path / "a" / "best.json").read_text()) == cost["best_settings"]
    tune("ppo_ff", tmp_path / "b", trials=3, steps=1, base=TINY, log=log.append)
    tune("ppo_ff", tmp_path / "a", trials=3, steps=1, base=TINY, log=log.append)  # continue: one more
    assert _params(tmp_path / "a") == _params(tmp_path / "b")
    assert len(_params(tmp_path / "a")) == 3


def test_an_interrupted_trial_runs_again_with_its_settings(tmp_path):
    tune("ppo_ff", tmp_path, trials=1, steps=1, base=TINY, log=lambda s: None)
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    study = optuna.load_study(study_name="lean_ppo_ff",
                              storage=JournalStorage(JournalFileBackend(str(tmp_path / STUDY_FILE))))
    cut = study.ask({"lr": optuna.distributions.FloatDistribution(1e-4, 3e-3, log=True)})  # left RUNNING
    log = []
    tune("ppo_ff", tmp_path, trials=2, steps=1, base=TINY, log=log.append)
    trials = _params(tmp_path)
    assert trials[cut.number][1] == "FAIL"
    assert trials[-1][1] == "COMPLETE" and trials[-1][2]["lr"] == cut.params["lr"]
    assert any("interrupted" in line for line in log)
    # the trial table: the finished trials as rows (the best in bold), the cut-off one counted, not a row
    table = trials_table(tmp_path, "ppo_ff").splitlines()
    rows = [line for line in table if line.startswith("| ") and "completed" in line]
    assert table[0].startswith("| trial | state | objective | robot-steps | CPU-s | lr |") and "frame_stack" in table[0]
    assert [r.split(" | ")[0] for r in rows] == ["| 0", f"| {trials[-1][0]}"] and sum("**" in r for r in rows) == 1
    assert table[-1] == "2 finished trials; 1 cut off by an interruption and run again"
    with pytest.raises(FileNotFoundError, match="no tuning journal"):
        trials_table(tmp_path / "nothing", "ppo_ff")


def test_objective_is_the_mean_of_the_last_tenth():
    rows = [{"fitness_mean": float(i)} for i in range(20)]
    assert objective_value(rows) == pytest.approx(18.5)
    with pytest.raises(ValueError):
        objective_value([])


def test_the_journal_alone_carries_the_tuning_cost(tmp_path):
    """Trial folders (checkpoints) are not kept between sessions, the study file is: the cost must survive."""
    import shutil

    before = tune("ppo_ff", tmp_path, trials=2, steps=1, base=TINY, log=lambda s: None)
    assert before["robot_steps"] > 0
    shutil.rmtree(tmp_path / "trials")
    kept = (tmp_path / STUDY_FILE).read_bytes()
    after = tune("ppo_ff", tmp_path, trials=2, steps=1, base=TINY, log=lambda s: None)  # nothing left to run
    assert after == before
    # the queue calls a finished study's tuning again every session: its kept journal must not change
    assert (tmp_path / STUDY_FILE).read_bytes() == kept
