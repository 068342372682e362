"""docs/results/in_progress/park.py: an experiment parked in the repository and restored elsewhere resumes to the
runs it would have made, a damaged checkpoint is never parked, and a restore never goes back in generations."""
from __future__ import annotations

import csv
import importlib.util
import json
import shutil
from pathlib import Path

import pytest

from mahn_evo.experiment import ExperimentPlan, run_experiment
from mahn_evo.storage.folder_lock import folder_lock
from mahn_evo.training.trainer import Trainer

ROOT = Path(__file__).resolve().parents[1]
SMALL = dict(modes=("situational",), runs=1, seed=3, generations=4, population=16, max_cycles=240, signal_tick=120,
             general_episodes=3, transfer_episodes=1, top=1, replays=0)


@pytest.fixture
def park(tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location("park", ROOT / "docs" / "results" / "in_progress" / "park.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "HERE", tmp_path / "parked")
    (tmp_path / "parked").mkdir()
    return module


def _rows(run: Path) -> list[list[str]]:
    with open(run / "log.csv") as f:
        return [row[:-1] for row in csv.reader(f)]  # without the wall-clock column


def _quiet(_msg: str) -> None:
    pass


def test_a_parked_experiment_resumes_elsewhere_to_the_same_runs(park, tmp_path):
    plan = ExperimentPlan(**SMALL)
    run_experiment(plan, tmp_path / "straight", workers=1, analyse=False, log=_quiet)
    plan.save_or_check(tmp_path / "host1")  # a session that stopped after 2 of 4 generations
    [(_, seed, folder)] = plan.tasks(tmp_path / "host1")
    t = Trainer(plan.train_config("situational", seed), folder)
    for _ in range(2):
        t.step()
    t._write_log()
    t._checkpoint()
    park.park(tmp_path / "host1", "exp")
    assert not list((tmp_path / "parked" / "exp").rglob(".mahn.lock")) and not list(
        (tmp_path / "parked" / "exp").rglob("*.png"))
    assert park.listing() == [{"experiment": "exp", "run": "situational_s003", "generations": 2, "finished": False}]
    park.restore("exp", tmp_path / "host2", log=_quiet)
    run_experiment(plan, tmp_path / "host2", workers=1, analyse=False, log=_quiet)
    run = "runs/situational_s003"
    assert _rows(tmp_path / "host2" / run) == _rows(tmp_path / "straight" / run)
    said: list[str] = []
    park.restore("exp", tmp_path / "host2", log=said.append)  # further along here: left as it is
    assert said == ["situational_s003: further along here (4 > 2 generations), left as it is"]
    assert _rows(tmp_path / "host2" / run) == _rows(tmp_path / "straight" / run)
    park.park(tmp_path / "host2", "exp")
    # as far along here: a finished run's report files (written after it was parked) stay, and a parked file the
    # folder lacks is copied in; the stop-49 restore replaced such a folder and lost its final validation
    (tmp_path / "host2" / run / "final_validation.json").write_text("{}")
    (tmp_path / "parked" / "exp" / run / "notes" / "extra.json").parent.mkdir()
    (tmp_path / "parked" / "exp" / run / "notes" / "extra.json").write_text("[]")
    said.clear()
    park.restore("exp", tmp_path / "host2", log=said.append)
    assert said == ["situational_s003: as far along here (4 generations), left as it is (1 parked file(s) it lacked "
                    "copied)"]
    assert (tmp_path / "host2" / run / "final_validation.json").read_text() == "{}"
    assert (tmp_path / "host2" / run / "notes" / "extra.json").read_text() == "[]"
    assert _rows(tmp_path / "host2" / run) == _rows(tmp_path / "straight" / run)
    said.clear()
    park.park(tmp_path / "host1", "exp", log=said.append)  # an older copy does not replace a newer parked one
    assert said == ["situational_s003: the parked copy is further along (4 > 2 generations): kept (--force "
                    "replaces it)"]
    assert park.listing()[0]["generations"] == 4
    park.park(tmp_path / "host1", "exp", force=True)
    assert park.listing()[0]["generations"] == 2
    ckpt = tmp_path / "host2" / run / "checkpoint.json"
    data = json.loads(ckpt.read_text())
    data["population"]["generation"] = 5  # a changed digit: its digest no longer matches
    ckpt.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="checkpoint"):
        park.park(tmp_path / "host2", "exp", force=True)
    assert park.listing()[0]["generations"] == 2  # the parked copy is untouched
    with folder_lock(tmp_path / "host1" / run):  # a run in use is never parked
        with pytest.raises(ValueError, match=r"\['situational_s003'\] .* are in use"):
            park.park(tmp_path / "host1", "exp")
    for bad in ("", "..", "a/b"):
        with pytest.raises(ValueError, match="name"):
            park.park(tmp_path / "host1", bad)
    assert (tmp_path / "parked" / "exp" / run / "checkpoint.json").exists()
    assert park.main(["restore", "nothing", str(tmp_path / "x")]) == 1


def _queue_commands() -> list[tuple[str, list[str]]]:
    """(program, arguments) of every step of queue.sh, its continuation lines joined, its settings (NAME=value,
    NAME=(...)) and the loop variables filled in."""
    import re
    import shlex

    text = (ROOT / "docs" / "results" / "in_progress" / "queue.sh").read_text().replace("\\\n", " ")
    arrays = {m.group(1): " ".join(shlex.split(m.group(2), comments=True))  # NAME=(...) arrays, as bash fills them
              for m in re.finditer(r"^(\w+)=\(([^)]*)\)", text, flags=re.M)}
    for name in list(arrays):
        for other, inner in list(arrays.items()):
            arrays[name] = arrays[name].replace(f'"${{{other}[@]}}"', inner)
    scalars = dict(re.findall(r"^(\w+)=(\w+)\b", text, flags=re.M))  # NAME=value settings, e.g. TRIALS=25
    out = []
    for line in text.splitlines():
        m = re.match(r"(?:\s*|.*\|\| )step python -m (mahn_evo\.cli|baselines) (.*?)( \|\| return)?$", line)
        if m:
            args = m.group(2)
            for name, value in scalars.items():
                args = args.replace(f"${name}", value)
            for name, value in arrays.items():
                args = args.replace(f'"${{{name}[@]}}"', value)
            args = re.sub(r'"\$\(cat [^)]*\)"', "{}", args).replace('"$steps"', "1e8")
            args = args.replace('"$m"', "ppo_ff").replace("$m", "ppo_ff").replace("${m}", "ppo_ff")
            out.append((m.group(1), shlex.split(args.replace("$s", "0"))))
    return out


def test_every_step_of_the_queue_is_a_command_the_clis_accept():
    """A step that fails goes on to the next (queue.sh): a step the CLI no longer accepts would be skipped
    silently in the background, so every step must parse."""
    from baselines.cli import build_parser as baselines_parser
    from mahn_evo.cli import build_parser as evo_parser

    steps = _queue_commands()
    # the robot-noise seeds; issue 12's tuning step (`tune`, one per method) and final runs (`final_pool`)
    assert [p for p, _ in steps].count("mahn_evo.cli") == 1 and [p for p, _ in steps].count("baselines") == 2
    for program, args in steps:
        parser = evo_parser() if program == "mahn_evo.cli" else baselines_parser()
        parser.parse_args(args)  # SystemExit on an unknown option or a bad value


def test_a_parked_lean_run_resumes_elsewhere_to_the_same_run(park, tmp_path):
    """Issue 12's lean PPO runs parked after 1 of 3 updates, restored in another folder and resumed: the same
    updates as the run made straight through; a run in use, or with damaged weights, is never parked."""
    pytest.importorskip("torch")
    from baselines.lean.config import LeanConfig
    from baselines.lean.ppo import train

    base = dict(method="ppo_ff", seed=3, max_cycles=60, signal_tick=30, n_episodes=2, hidden=8, eval_maps=["plus"])
    per_update = 2 * 3 * 60
    train(LeanConfig(steps=3 * per_update, **base), tmp_path / "straight" / "ppo_ff_seed3")
    train(LeanConfig(steps=1 * per_update, **base), tmp_path / "host1" / "ppo_ff_seed3")
    (tmp_path / "host1" / "tune_ppo_ff").mkdir()  # a tuning folder is not a lean run: left out
    park.park_lean(tmp_path / "host1", "fair")
    assert [row for row in park.listing() if "lean_runs" in row] == [
        {"lean_runs": "fair", "run": "ppo_ff_seed3", "updates": 1, "finished": True}]
    park.restore_lean("fair", tmp_path / "host2", log=_quiet)
    run = tmp_path / "host2" / "ppo_ff_seed3"
    train(LeanConfig(steps=3 * per_update, **base), run, resume=True)
    a = json.loads((tmp_path / "straight" / "ppo_ff_seed3" / "checkpoint.json").read_text())
    b = json.loads((run / "checkpoint.json").read_text())
    timing = ("wall_time", "cpu_seconds", "robot_steps_per_second")
    assert b["update"] == 3 and a["rng"] == b["rng"]
    assert [{k: v for k, v in r.items() if k not in timing} for r in a["train_rows"]] == \
        [{k: v for k, v in r.items() if k not in timing} for r in b["train_rows"]]
    said: list[str] = []
    park.restore_lean("fair", tmp_path / "host2", log=said.append)  # further along here: left as it is
    assert said == ["ppo_ff_seed3: further along here (3 > 1 updates), left as it is"]
    with folder_lock(run):
        with pytest.raises(ValueError, match=r"\['ppo_ff_seed3'\] .* are in use"):
            park.park_lean(tmp_path / "host2", "fair")
    weights = run / b["weights"]
    weights.write_bytes(weights.read_bytes()[:-40])  # a truncated weights file
    with pytest.raises(ValueError, match="weights"):
        park.park_lean(tmp_path / "host2", "fair")
    assert park.updates(tmp_path / "parked" / "fair" / "ppo_ff_seed3") == 1  # the parked copy is untouched


def test_park_all_parks_what_a_session_ran(park, tmp_path, monkeypatch):
    """The session's closing step: experiments parked before are parked again (one never parked is named, not
    parked), the lean PPO runs of fair/ are parked (but one finished and kept in fair_runs/), and the tuning
    journals kept unless the kept one is longer."""
    pytest.importorskip("torch")
    from baselines.lean.config import LeanConfig
    from baselines.lean.ppo import train

    monkeypatch.setattr(park, "FAIR_RUNS", tmp_path / "fair_runs")
    host = tmp_path / "runs"
    plan = ExperimentPlan(**SMALL)
    plan.save_or_check(host / "exp")
    [(_, seed, folder)] = plan.tasks(host / "exp")
    t = Trainer(plan.train_config("situational", seed), folder)
    t.step()
    t._write_log()
    t._checkpoint()
    park.park(host / "exp", "exp")
    shutil.copytree(host / "exp", host / "other")
    t.step()
    t._write_log()
    t._checkpoint()
    train(LeanConfig(method="ppo_ff", seed=3, max_cycles=60, signal_tick=30, n_episodes=2, hidden=8,
                     eval_maps=["plus"], steps=360), host / "fair" / "ppo_ff_seed3")
    shutil.copytree(host / "fair" / "ppo_ff_seed3", host / "fair" / "ppo_ff_seed0")  # finished and kept:
    (tmp_path / "fair_runs" / "ppo_ff_seed0").mkdir(parents=True)                     # not parked again
    shutil.copy2(host / "fair" / "ppo_ff_seed3" / "summary.json", tmp_path / "fair_runs" / "ppo_ff_seed0")
    (host / "fair" / "ppo_ff_seed0" / "summary.json").unlink()  # here short of its end, kept finished: finished
    # `finished`, as queue.sh asks it (exit status): by the run's summary here or by its kept copy's, at the budget
    assert park.main(["finished", str(host / "fair" / "ppo_ff_seed3"), "360"]) == 0
    assert park.main(["finished", str(host / "fair" / "ppo_ff_seed3"), "361"]) == 1
    assert park.main(["finished", str(host / "fair" / "ppo_ff_seed0"), "360"]) == 0
    assert park.main(["finished", str(host / "fair" / "ppo_ff_seed9"), "1"]) == 1  # no such run
    for name, lines in (("tune_ppo_ff", 3), ("tune_mappo_gru", 2)):
        (host / "fair" / name).mkdir()
        (host / "fair" / name / "study.jsonl").write_text("{}\n" * lines)
    (tmp_path / "fair_runs" / "tune_mappo_gru").mkdir(parents=True)
    (tmp_path / "fair_runs" / "tune_mappo_gru" / "study.jsonl").write_text("{}\n" * 5)  # further along
    said: list[str] = []
    park.park_all(host, log=said.append)
    assert "other: not parked before (park it by name once, if it is to be kept)" in said
    assert "tune_mappo_gru: the kept journal is further along (5 > 2 lines): kept" in said
    assert "ppo_ff_seed0: finished and kept in fair_runs/, not parked" in said
    rows = park.listing()
    assert [(r.get("experiment"), r.get("generations")) for r in rows if "experiment" in r] == [("exp", 2)]
    assert [(r["run"], r["updates"]) for r in rows if "lean_runs" in r] == [("ppo_ff_seed3", 1)]
    assert (tmp_path / "fair_runs" / "tune_ppo_ff" / "study.jsonl").read_text() == "{}\n" * 3
    assert (tmp_path / "fair_runs" / "tune_mappo_gru" / "study.jsonl").read_text() == "{}\n" * 5
