"""The training loop: determinism, bit-identical resume, run-folder files, CLI, eval agreement, progress."""
import csv
import json

import pytest

from mahn_envs import BatchSim, patrol_return_v0
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.cli import main
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer, train


def small(**kw):
    base = dict(generations=4, init="minimal", seed=3)
    base.update(kw)
    pop = base.pop("pop", 24)
    return EvolutionConfig(**base).with_overrides(pop=pop)


def _log(path):
    with open(path / "log.csv") as f:
        return list(csv.DictReader(f))


def test_same_seed_same_run(tmp_path):
    a = train(small(), tmp_path / "a")
    b = train(small(), tmp_path / "b")
    assert a["best_fitness"] == b["best_fitness"]
    ra, rb = _log(tmp_path / "a"), _log(tmp_path / "b")
    assert [(r["best_fitness"], r["mean_fitness"], r["n_species"]) for r in ra] == \
           [(r["best_fitness"], r["mean_fitness"], r["n_species"]) for r in rb]
    train(small(seed=4), tmp_path / "c")
    assert [r["mean_fitness"] for r in _log(tmp_path / "c")] != [r["mean_fitness"] for r in ra]


def test_resume_is_bit_identical(tmp_path):
    full = train(small(generations=6), tmp_path / "full")
    t = Trainer(small(generations=3), tmp_path / "part")
    t.run()
    resumed = train(small(generations=6), tmp_path / "part", resume=True)
    assert resumed["best_fitness"] == full["best_fitness"]
    drop = lambda rows: [{k: v for k, v in r.items() if k != "seconds"} for r in rows]  # noqa: E731
    assert drop(_log(tmp_path / "part")) == drop(_log(tmp_path / "full"))
    a = json.loads((tmp_path / "full" / "checkpoint.json").read_text())["population"]
    b = json.loads((tmp_path / "part" / "checkpoint.json").read_text())["population"]
    assert a == b


def test_run_folder_files(tmp_path):
    summary = train(small(), tmp_path)
    for name in ("config.json", "log.csv", "checkpoint.json", "champion.json", "summary.json", "fitness.png"):
        assert (tmp_path / name).exists(), name
    assert set(summary) >= {"mode", "seed", "generations", "best_fitness", "solved", "first_solved_generation"}
    assert summary["generations"] == 4 and len(_log(tmp_path)) == 4
    champ = Champion.load(tmp_path / "champion.json")
    assert champ.fitness == pytest.approx(summary["best_fitness"])
    assert champ.controllers.n_brains == 2


def test_refuses_to_overwrite_or_resume_differently(tmp_path):
    train(small(), tmp_path)
    with pytest.raises(ValueError, match="--resume"):
        Trainer(small(), tmp_path)
    with pytest.raises(ValueError, match="seed"):
        Trainer(small(seed=99), tmp_path, resume=True)


def test_corrupt_and_old_files_give_clear_errors(tmp_path):
    train(small(generations=1), tmp_path)
    ck = tmp_path / "checkpoint.json"
    ck.write_text(ck.read_text()[:100])
    with pytest.raises(ValueError, match="corrupt"):
        Trainer(small(), tmp_path, resume=True)
    champ = json.loads((tmp_path / "champion.json").read_text())
    champ["version"] = 0
    (tmp_path / "old.json").write_text(json.dumps(champ))
    with pytest.raises(ValueError, match="version 0"):
        Champion.load(tmp_path / "old.json")


@pytest.mark.parametrize("mode", ["situational", "standard"])
def test_trainer_fitness_equals_env_fitness(tmp_path, mode):
    train(small(mode=mode, generations=2), tmp_path)
    champ = Champion.load(tmp_path / "champion.json")
    env = patrol_return_v0.parallel_env()
    obs, _ = env.reset(seed=0)
    policy = ControllerPolicy(champ.controllers, env.possible_agents)
    while env.agents:
        obs, rew, te, tr, infos = env.step(policy.act(obs))
    assert infos["robot_0"]["team_fitness"] == pytest.approx(champ.fitness, abs=1e-9)
    assert BatchSim("plus", 1).run_controllers(champ.controllers).fitness[0] == pytest.approx(champ.fitness, abs=1e-12)


def test_cli_train_and_eval(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["train", "--generations", "2", "--pop", "16", "--init", "minimal", "--out", str(out), "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["generations"] == 2
    assert main(["eval", str(out / "champion.json"), "--json", "--engine", "pymunk"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["fitness"] == pytest.approx(summary["best_fitness"], abs=1e-9)
    assert main(["eval", str(out / "champion.json"), "--map", "asymmetric_plus", "--noise", "generalization",
                 "--episodes", "3", "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["episode_fitness"]) == 3
    assert main(["eval", str(tmp_path / "missing.json")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_evolution_makes_progress():
    """Smoke version of the learning experiment: a short run must beat its own first generation."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        t = Trainer(small(generations=12, pop=60, seed=1), d)
        t.run()
        rows = t.rows
    first, last = rows[0][2], max(r[4] for r in rows)
    assert last > first + 0.2, (first, last)
    assert last > 2.0232671157474424 + 0.5  # well above the all-forward team


def test_default_init_makes_progress():
    """The default (the paper's seed genome, modules evaluated) starts as the all-forward team's 2.0233 and
    must leave it within a small budget."""
    import tempfile

    assert (EvolutionConfig().init, EvolutionConfig().evaluate_modules) == ("iros2011", True)
    with tempfile.TemporaryDirectory() as d:
        t = Trainer(EvolutionConfig(generations=15, seed=2).with_overrides(pop=80), d)
        t.run()
    assert max(r[4] for r in t.rows) > 2.5


def test_after_solved_keeps_running_and_may_change_on_resume(tmp_path):
    t = Trainer(small(generations=50, stop_when_solved=True, after_solved=2), tmp_path / "r")
    t.step()
    t.first_solved = 0  # as if generation 0 had held a solution
    assert not t.done()
    t.step()
    t.step()
    assert t.done() and t.generation == 3  # generations 0..2: the solution's and two more
    t.finish()
    resumed = Trainer(small(generations=50, stop_when_solved=True, after_solved=5), tmp_path / "r", resume=True)
    assert resumed.generation == 3 and not resumed.done()
    assert json.loads((tmp_path / "r" / "config.json").read_text())["after_solved"] == 5
    with pytest.raises(ValueError, match="seed"):
        Trainer(small(generations=50, seed=9, stop_when_solved=True), tmp_path / "r", resume=True)
    with pytest.raises(ValueError, match="after_solved"):
        small(after_solved=-1)


def test_atomic_writes_leave_no_temp_files_and_normal_permissions(tmp_path):
    import os

    from mahn_evo.storage.files import atomic_write_json, read_versioned_json, versioned

    path = tmp_path / "x.json"
    atomic_write_json(path, versioned("thing", {"a": 1}))
    atomic_write_json(path, versioned("thing", {"a": 2}))
    assert read_versioned_json(path, "thing")["a"] == 2
    assert [p.name for p in tmp_path.iterdir()] == ["x.json"]
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask
