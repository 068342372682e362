"""Direct-encoding CMA-ES: the substrate's networks, the trainer's evaluator, beats a random team, resumes
bit-identically by replay."""
from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("cma")

from baselines.comparison.compare import evo_curve  # noqa: E402
from baselines.direct.cmaes import CMAConfig, DirectCMA, DirectEncoding, train  # noqa: E402
from mahn_envs.core.batch import BatchSim  # noqa: E402
from mahn_envs.core.params import TaskParams  # noqa: E402
from mahn_evo.hyperneat.substrate import query_layout  # noqa: E402

SHORT = dict(max_cycles=300, signal_tick=150)


@pytest.mark.parametrize("mode,n", [("standard", 549), ("situational", 1044)])
def test_encoding_covers_the_substrate_connections(mode, n):
    enc = DirectEncoding(mode)
    assert enc.n_params == n
    x = np.random.default_rng(0).normal(0, 2, (4, n))
    c = enc.decode(x)
    assert c.w_ih.shape == (4, 3, 2 if mode == "situational" else 1, 9, 7)
    layout = query_layout(mode)
    assert np.all(c.w_ih[:, layout.q_ih < 0] == 0)  # no signal input in situational geometry
    assert np.abs(c.w_hh).max() <= 3.0 and np.abs(c.b_o).max() <= 3.0  # HyperNEAT's range
    # every parameter lands in exactly one place
    total = sum(int(np.count_nonzero(getattr(c, f)[0])) for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o"))
    assert total == n
    with pytest.raises(ValueError, match="values"):
        enc.decode(np.zeros((1, n + 1)))


def test_a_short_run_beats_a_random_team(tmp_path):
    """5 generations of 16 teams, seed 0, on the 300-tick task: best team 0.22 against a random team's 0.086."""
    cfg = CMAConfig(mode="situational", generations=5, popsize=16, seed=0, **SHORT)
    summary = train(cfg, tmp_path / "run")
    random_fitness = BatchSim("plus", 64, TaskParams(**SHORT)).run_random(seed=0).fitness.mean()
    assert summary["best_fitness"] > 2 * random_fitness
    assert summary["evaluations"] == 80 and summary["robot_steps"] == 80 * 300 * 3
    best = json.loads((tmp_path / "run" / "best_controllers.json").read_text())
    assert best["fitness"] == summary["best_fitness"]
    # the comparison reads the run like an evolution run, under its own method name
    curve = evo_curve(tmp_path / "run", ticks=300)
    assert curve.method == "cmaes_direct_situational" and curve.budget[-1] == 80 * 300 * 3


def test_resume_replays_to_the_same_search(tmp_path):
    base = dict(mode="standard", popsize=6, seed=4, max_cycles=60, signal_tick=30)
    train(CMAConfig(generations=6, **base), tmp_path / "straight", checkpoint_every=2)
    train(CMAConfig(generations=3, **base), tmp_path / "resumed", checkpoint_every=2)
    train(CMAConfig(generations=6, **base), tmp_path / "resumed", resume=True, checkpoint_every=2)
    a = json.loads((tmp_path / "straight" / "checkpoint.json").read_text())
    b = json.loads((tmp_path / "resumed" / "checkpoint.json").read_text())
    assert a["digest"] == b["digest"] and a["generation"] == b["generation"] == 6
    assert [r[:-2] for r in a["log"]] == [r[:-2] for r in b["log"]]  # all but the CPU and wall seconds
    # same seed, same search; another seed, another search
    train(CMAConfig(generations=6, **{**base, "seed": 5}), tmp_path / "other")
    c = json.loads((tmp_path / "other" / "checkpoint.json").read_text())
    assert c["digest"] != a["digest"]


def test_resume_refuses_other_settings_and_a_damaged_history(tmp_path):
    base = dict(mode="standard", popsize=4, seed=0, max_cycles=60, signal_tick=30)
    train(CMAConfig(generations=2, **base), tmp_path / "run")
    with pytest.raises(ValueError, match="popsize"):
        DirectCMA(CMAConfig(generations=4, **{**base, "popsize": 8}), tmp_path / "run", resume=True)
    with pytest.raises(ValueError, match="already holds a run"):
        DirectCMA(CMAConfig(generations=4, **base), tmp_path / "run")
    (tmp_path / "run" / "history.npz").write_bytes(b"garbage")
    with pytest.raises(ValueError, match="history.npz"):
        DirectCMA(CMAConfig(generations=4, **base), tmp_path / "run", resume=True)


def test_config_rejects_bad_settings():
    with pytest.raises(ValueError, match="mode"):
        CMAConfig(mode="hybrid")
    with pytest.raises(ValueError, match="popsize"):
        CMAConfig(popsize=1)
    with pytest.raises(ValueError, match="sigma0"):
        CMAConfig(sigma0=0.0)


def test_cli_cmaes_starts_then_resumes_with_one_command(tmp_path, capsys):
    from baselines.cli import main

    args = ["cmaes", "--mode", "standard", "--popsize", "4", "--seed", "2", "--out", str(tmp_path / "run"),
            "--resume", "--max-cycles", "60", "--signal-tick", "30"]
    assert main(args + ["--generations", "2"]) == 0
    assert main(args + ["--generations", "3"]) == 0
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["generations"] == 3 and summary["method"] == "cmaes_direct_standard"


def test_a_finished_run_is_not_replayed(tmp_path, monkeypatch):
    base = dict(mode="standard", popsize=4, seed=0, max_cycles=60, signal_tick=30)
    first = train(CMAConfig(generations=2, **base), tmp_path / "run")
    monkeypatch.setattr(DirectCMA, "__init__", lambda *a, **k: pytest.fail("replayed a finished run"))
    assert train(CMAConfig(generations=2, **base), tmp_path / "run", resume=True) == first


def test_restarts_double_the_population_within_the_budget_and_resume_by_replay(tmp_path):
    """IPOP: on the 60-tick task no search gains 0.1 fitness in 2 generations, so the first search (4 candidates)
    restarts after generation 2 with 8; the budget of 6 x 4 = 24 candidates then allows one generation of 8."""
    base = dict(mode="standard", popsize=4, seed=3, max_cycles=60, signal_tick=30, restart_patience=2)
    straight = train(CMAConfig(generations=6, **base), tmp_path / "straight", checkpoint_every=1)
    assert straight["searches"] == [{"generation": 0, "popsize": 4}, {"generation": 3, "popsize": 8}]
    assert straight["generations"] == 4 and straight["evaluations"] == 3 * 4 + 8 <= 24
    with np.load(tmp_path / "straight" / "history.npz") as f:
        assert list(f["popsizes"]) == [4, 4, 4, 8] and f["fitness"].shape == (20,)
    log = json.loads((tmp_path / "straight" / "checkpoint.json").read_text())["log"]
    assert [r[1] for r in log] == [4, 8, 12, 20]  # evaluations, cumulative
    assert log[3][7] == pytest.approx(CMAConfig().sigma0, rel=0.5)  # the new search starts at sigma0 again
    # stopped at a budget of 3 generations (the restart already due), then resumed to 6: the same search
    train(CMAConfig(generations=3, **base), tmp_path / "resumed")
    resumed = train(CMAConfig(generations=6, **base), tmp_path / "resumed", resume=True)
    a = json.loads((tmp_path / "straight" / "checkpoint.json").read_text())
    b = json.loads((tmp_path / "resumed" / "checkpoint.json").read_text())
    assert a["digest"] == b["digest"] and [r[:-2] for r in a["log"]] == [r[:-2] for r in b["log"]]
    assert resumed["searches"] == straight["searches"] and b["budget_spent"] == 24
    assert straight["method"] == "ipop_cmaes_direct_standard"  # kept apart from single searches in comparisons
    # a history whose population sizes disagree with the restarts is not this run's
    with np.load(tmp_path / "resumed" / "history.npz") as f:
        fitness = f["fitness"]
    np.savez(tmp_path / "resumed" / "history.npz", fitness=fitness, popsizes=np.array([4, 4, 4, 4, 4]))
    with pytest.raises(ValueError, match="generation 3, whose search asks 8"):
        DirectCMA(CMAConfig(generations=8, **base), tmp_path / "resumed", resume=True)
    np.savez(tmp_path / "resumed" / "history.npz", fitness=fitness[:7], popsizes=np.array([4, 4, 4, 8]))
    with pytest.raises(ValueError, match="is damaged"):
        DirectCMA(CMAConfig(generations=8, **base), tmp_path / "resumed", resume=True)
    with pytest.raises(ValueError, match="restart_patience"):
        CMAConfig(restart_patience=-1)


def test_a_history_written_before_restarts_still_resumes(tmp_path):
    """Runs made before restarts (situational seeds 1-2 at HyperNEAT's budget) saved a (generations x popsize)
    array: they replay to the same search."""
    base = dict(mode="standard", popsize=4, seed=1, max_cycles=60, signal_tick=30)
    train(CMAConfig(generations=3, **base), tmp_path / "run")
    with np.load(tmp_path / "run" / "history.npz") as f:
        old = f["fitness"].reshape(3, 4)
    np.savez(tmp_path / "run" / "history.npz", fitness=old)
    saved = json.loads((tmp_path / "run" / "checkpoint.json").read_text())
    run = DirectCMA(CMAConfig(generations=5, **base), tmp_path / "run", resume=True)
    assert run.generation == 3 and run.searches == [0]
    run.run()
    straight = train(CMAConfig(generations=5, **base), tmp_path / "straight")
    assert json.loads((tmp_path / "run" / "checkpoint.json").read_text())["digest"] == json.loads(
        (tmp_path / "straight" / "checkpoint.json").read_text())["digest"] != saved["digest"]
    assert "searches" not in straight  # one search: the summary of runs without restarts
