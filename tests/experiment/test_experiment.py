"""`mahn-evo experiment`: plan checks, the table and Fisher's test, a small end-to-end experiment, resume after an
interruption, and the Ray backend giving the same runs as local processes."""
import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import fisher_exact

from mahn_evo.cli import main
from mahn_evo.experiment import ExperimentPlan, run_experiment
from mahn_evo.experiment.report import write_results
from mahn_evo.experiment.table import RunRecord, fisher, mode_table
from mahn_evo.experiment.transfer import robust_on_every_map
from mahn_evo.training.trainer import Trainer

SMALL = dict(runs=2, seed=5, generations=3, population=16, max_cycles=240, signal_tick=120, general_episodes=3,
             transfer_episodes=1, top=1, replays=0)


def _rows(run_dir: Path) -> list[list[str]]:
    """A run's log without the wall-clock column."""
    with open(run_dir / "log.csv") as f:
        return [row[:-1] for row in csv.reader(f)]


def _quiet(_msg: str) -> None:
    pass


def test_plan_validation_and_refusal(tmp_path):
    with pytest.raises(ValueError, match="modes"):
        ExperimentPlan(modes=("situational", "nope"))
    with pytest.raises(ValueError, match="runs"):
        ExperimentPlan(runs=0)
    with pytest.raises(ValueError, match="init"):
        ExperimentPlan(init="random")
    plan = ExperimentPlan(**SMALL)
    plan.save_or_check(tmp_path)
    ExperimentPlan(**{**SMALL, "runs": 4, "top": 1}).save_or_check(tmp_path)  # more runs: allowed
    ExperimentPlan(**{**SMALL, "modes": ("situational",)}).save_or_check(tmp_path)  # a mode run on its own: allowed
    with pytest.raises(ValueError, match="population"):
        ExperimentPlan(**{**SMALL, "population": 20}).save_or_check(tmp_path)
    cfg = plan.train_config("standard", 7)
    assert (cfg.mode, cfg.seed, cfg.neat.population_size, cfg.task.max_cycles) == ("standard", 7, 16, 240)
    assert cfg.stop_when_solved and cfg.after_solved == plan.after_solved


def test_a_plan_saved_before_the_tie_rule_keeps_its_rule(tmp_path):
    ExperimentPlan(**SMALL).save_or_check(tmp_path)
    saved = json.loads((tmp_path / "experiment.json").read_text())
    assert saved["neat"] == {"tie_break": "youngest", "respeciate_parents_first": True}  # a plan names its rules
    saved["neat"] = {}  # as written before the rule was recorded (format version 1)
    saved["version"] = 1
    (tmp_path / "experiment.json").write_text(json.dumps(saved))
    old = ExperimentPlan.load(tmp_path)
    neat = old.train_config("situational", 5).neat
    assert neat.tie_break == "oldest" and not neat.respeciate_parents_first
    with pytest.raises(ValueError, match=r"\['neat'\].*'tie_break': 'oldest'.*--config"):
        ExperimentPlan(**SMALL).save_or_check(tmp_path)
    ExperimentPlan(**{**SMALL, "neat": {"tie_break": "oldest", "respeciate_parents_first": False}}
                   ).save_or_check(tmp_path)


def _record(mode, seed, first, gens=1000):
    best = np.linspace(1, 150 if first is not None else 50, gens)
    return RunRecord(f"{mode}_s{seed:03d}", mode, seed, Path("."), True, gens, first is not None, first,
                     float(best.max()), 1.0, best)


def test_table_and_fisher_on_the_papers_counts():
    plan = ExperimentPlan(runs=15)
    firsts = [10, 50, 90, 200, 300, 400, 120, 33, 999, 5, 640, 70, 260, 410, 180]
    runs = [_record("situational", s, f) for s, f in enumerate(firsts)]
    runs += [_record("standard", s, f) for s, f in enumerate([100, 500, 800] + [None] * 12)]
    table = mode_table(plan, runs)
    gens = np.array(firsts) + 1
    assert table["situational"]["solved"] == 15 and table["standard"]["solved"] == 3
    assert table["situational"]["generations_mean"] == pytest.approx(gens.mean())
    assert table["situational"]["generations_sd"] == pytest.approx(gens.std(ddof=1))
    test = fisher(table, plan.modes)
    assert test["table"] == [[15, 0], [3, 12]]
    assert test["p_value"] == pytest.approx(fisher_exact([[15, 0], [3, 12]]).pvalue)
    assert test["p_value"] < 1e-4  # the paper's 15/15 vs 3/15 is p < 0.0001


def test_small_experiment_end_to_end_and_report_only(tmp_path):
    out = tmp_path / "exp"
    plan = ExperimentPlan(**{**SMALL, "replays": 1})
    results = run_experiment(plan, out, workers=2, log=_quiet)
    saved = json.loads((out / "results.json").read_text())
    assert saved["kind"] == "experiment_results" and saved["table"] == json.loads(json.dumps(results["table"]))
    for mode in plan.modes:
        t = results["table"][mode]
        assert t["runs_finished"] == 2 and t["runs_in_progress"] == 0
        assert len(results["most_general"][mode]) == 1
        for e in results["most_general"][mode]:
            assert set(e["transfer"]) == {"plus", "asymmetric_plus", "transfers", "margins"}
            m = e["transfer"]["margins"]
            assert m["decisions"] > 0 and 0.0 <= m["tied_fraction"] <= m["near_tie_fraction"] <= 1.0
            assert (out / e["file"]).exists()
    for run in results["runs"]:
        assert run["finished"] and run["generations"] == 3
        summary = json.loads((out / "runs" / run["run"] / "summary.json").read_text())
        assert summary["best_fitness"] == pytest.approx(run["best_fitness"])
    md = (out / "results.md").read_text()
    assert "| situational | 2 | 0 |" in md and "Fisher's exact test" in md
    for mode in plan.modes:
        n_robust = sum(robust_on_every_map(e["transfer"]) for e in results["most_general"][mode])
        assert f"| {mode}: **{n_robust}/1** succeed in at least 80% of the noisy sequential episodes on both " \
               "maps (robust) |" in md
    for fig in results["figures"]:
        assert (out / fig).stat().st_size > 1000
    assert len(results["replays"]) == 2 * 2 * 2  # modes x maps x protocols
    for film in results["replays"]:
        assert (out / film).stat().st_size > 10000 and film in md
    with open(out / "runs.csv") as f:
        assert len(list(csv.DictReader(f))) == 4
    # --report-only reads the saved plan and starts nothing
    before = {p: p.stat().st_mtime_ns for p in (out / "runs").glob("*/log.csv")}
    assert main(["experiment", "--report-only", "--out", str(out)]) == 0
    assert before == {p: p.stat().st_mtime_ns for p in (out / "runs").glob("*/log.csv")}
    # a report option given with --report-only replaces the saved one, in experiment.json too; others are ignored
    assert main(["experiment", "--report-only", "--general-episodes", "2", "--seed", "9", "--out", str(out)]) == 0
    assert ExperimentPlan.load(out) == replace(plan, general_episodes=2)
    assert json.loads((out / "results.json").read_text())["plan"]["general_episodes"] == 2
    assert main(["experiment", "--report-only", "--general-episodes", "3", "--out", str(out)]) == 0
    assert ExperimentPlan.load(out) == plan
    # the transfer tests ran on two worker processes; one process gives the same numbers
    serial = write_results(plan, out, log=_quiet, workers=1)
    for mode in plan.modes:
        assert [e["transfer"] for e in serial["most_general"][mode]] == \
            [e["transfer"] for e in results["most_general"][mode]]
    # --final-validation N validates every finished run's final population once (again only when N or the run
    # changes) before the report ranks the archives
    assert not list((out / "runs").glob("*/final_validation.json"))
    assert main(["experiment", "--report-only", "--final-validation", "2", "--out", str(out)]) == 0
    assert ExperimentPlan.load(out) == replace(plan, final_validation=2)
    records = sorted((out / "runs").glob("*/final_validation.json"))
    assert len(records) == 4 and all(json.loads(p.read_text())["episodes"] == 2 for p in records)
    assert "validation episodes of its own" in (out / "results.md").read_text()
    stamps = [p.stat().st_mtime_ns for p in records]
    assert main(["experiment", "--report-only", "--out", str(out)]) == 0
    assert stamps == [p.stat().st_mtime_ns for p in records]
    # --final-sequential T validates again with the sequential stage (a new choice rule), and says so
    assert main(["experiment", "--report-only", "--final-sequential", "1", "--out", str(out)]) == 0
    assert ExperimentPlan.load(out) == replace(plan, final_validation=2, final_sequential=1)
    assert stamps != [p.stat().st_mtime_ns for p in records]
    assert all(json.loads(p.read_text())["sequential"]["teams"] == 1 for p in records)
    assert "sequential protocol on the training map" in (out / "results.md").read_text()
    with pytest.raises(ValueError, match="give final_validation"):
        replace(plan, final_sequential=3)
    # --final-family F needs runs trained on plus variants (these were not: a clear error, nothing validated) and
    # the sequential stage
    with pytest.raises(ValueError, match="give final_sequential"):
        replace(plan, final_validation=2, final_family=2)
    stamps = [p.stat().st_mtime_ns for p in records]
    assert main(["experiment", "--report-only", "--final-family", "1", "--out", str(out)]) == 2
    assert stamps == [p.stat().st_mtime_ns for p in records]
    assert ExperimentPlan.load(out) == replace(plan, final_validation=2, final_sequential=1)  # the plan unchanged
    # --final-engine batch validates again, the sequential stage in the compiled core; --general-from
    # final_validation transfers each run's pick (these runs have none: their archives' most general stand in)
    assert main(["experiment", "--report-only", "--final-engine", "batch", "--general-from", "final_validation",
                 "--out", str(out)]) == 0
    assert ExperimentPlan.load(out) == replace(plan, final_validation=2, final_sequential=1, final_engine="batch",
                                               general_from="final_validation")
    assert stamps != [p.stat().st_mtime_ns for p in records]
    assert all(json.loads(p.read_text())["sequential"]["engine"] == "batch" for p in records)
    md = (out / "results.md").read_text()
    assert "`--final-engine batch`" in md and "`--general-from final_validation`" in md
    assert "`--general-rank protocol`" not in md
    # --general-rank protocol ranks by the picks' validation successes (no pick here: 0 each) and says so
    assert main(["experiment", "--report-only", "--general-rank", "protocol", "--out", str(out)]) == 0
    assert ExperimentPlan.load(out).general_rank == "protocol"
    results = json.loads((out / "results.json").read_text())
    assert all(e["validation_protocol_successes"] == 0 for es in results["most_general"].values() for e in es)
    assert "`--general-rank protocol`" in (out / "results.md").read_text()


def test_interrupted_experiment_resumes_bit_identically(tmp_path):
    plan = ExperimentPlan(**{**SMALL, "modes": ("situational",)})
    run_experiment(plan, tmp_path / "straight", workers=1, analyse=False, log=_quiet)
    # an interrupted experiment: one run stopped after 1 generation, the other never started
    plan.save_or_check(tmp_path / "cut")
    (_, seed, folder), _ = plan.tasks(tmp_path / "cut")
    cfg = plan.train_config("situational", seed)
    t = Trainer(cfg, folder)
    t.step()
    t._write_log()
    t._checkpoint()
    assert len(_rows(folder)) == 2
    run_experiment(plan, tmp_path / "cut", workers=2, analyse=False, log=_quiet)
    for _, _, f in plan.tasks(tmp_path / "straight"):
        assert _rows(f) == _rows(tmp_path / "cut" / "runs" / f.name)


def test_an_experiment_split_by_seed_makes_the_runs_of_the_whole(tmp_path):
    """--only-seeds runs part of an experiment (split across machines, lost runs redone): the same runs."""
    plan = ExperimentPlan(**{**SMALL, "modes": ("situational",)})
    run_experiment(plan, tmp_path / "whole", workers=1, analyse=False, log=_quiet)
    with pytest.raises(ValueError, match=r"--only-seeds must name seeds of the experiment \(5-6\), got \[4, 5\]"):
        run_experiment(plan, tmp_path / "part", workers=1, analyse=False, log=_quiet, only_seeds=[5, 4])
    run_experiment(plan, tmp_path / "part", workers=1, analyse=False, log=_quiet, only_seeds=[6])
    assert [f.name for f in (tmp_path / "part" / "runs").iterdir()] == ["situational_s006"]
    run_experiment(plan, tmp_path / "part", workers=1, analyse=False, log=_quiet, only_seeds=[5])
    for _, _, f in plan.tasks(tmp_path / "whole"):
        assert _rows(f) == _rows(tmp_path / "part" / "runs" / f.name)


def test_only_seeds_with_report_only_is_refused(tmp_path, capsys):
    assert main(["experiment", "--out", str(tmp_path / "e"), "--only-seeds", "1", "--report-only"]) != 0
    assert "--report-only runs none" in capsys.readouterr().err


def test_ray_backend_gives_the_same_runs(tmp_path):
    plan = ExperimentPlan(**{**SMALL, "runs": 1})
    run_experiment(plan, tmp_path / "local", workers=2, analyse=False, log=_quiet)
    run_experiment(plan, tmp_path / "ray", backend="ray", workers=2, analyse=False, log=_quiet)
    for _, _, f in plan.tasks(tmp_path / "local"):
        assert _rows(f) == _rows(tmp_path / "ray" / "runs" / f.name)
        a = json.loads((f / "champion.json").read_text())
        b = json.loads((tmp_path / "ray" / "runs" / f.name / "champion.json").read_text())
        assert a == b


def _write_log(folder: Path, solved_generations: set[int], gens: int = 12) -> None:
    """A run's log.csv as the trainer writes it, with teams solved in `solved_generations`."""
    from mahn_evo.storage.files import atomic_write_csv
    from mahn_evo.training.trainer import LOG_HEADER

    rows = [[g, 500 * (g + 1), 160.0 if g in solved_generations else 50.0, 20.0, 160.0, g in solved_generations,
             3 if g in solved_generations else 0, 40, 3.0, 40.0, 0.2] for g in range(gens)]
    folder.mkdir(parents=True)
    atomic_write_csv(folder / "log.csv", LOG_HEADER, rows)


def test_the_table_counts_runs_that_solve_under_noise_in_their_robust_phase(tmp_path):
    from mahn_evo.experiment.report import _robust_text
    from mahn_evo.experiment.table import load_run

    plan = ExperimentPlan(modes=("situational",), runs=3, noise="generalization", episodes=3,
                          noise_draws="per_generation", noise_free_episode=True, robust_from="first_solution",
                          robust_delay=2, after_solved=8)
    # first solution at 3: generations 4 and 5 are noise-free, the robust phase starts at 6
    _write_log(tmp_path / "kept", {3, 4, 5, 9})
    _write_log(tmp_path / "lost", {3, 4, 5})
    _write_log(tmp_path / "never", set())
    runs = [load_run(plan, "situational", s, tmp_path / name) for s, name in ((1, "kept"), (2, "lost"), (3, "never"))]
    assert [r.solved_under_noise for r in runs] == [True, False, False]
    assert [r.first_solved for r in runs] == [3, 3, None]
    finished = [replace(r, finished=True) for r in runs]
    t = mode_table(plan, finished)["situational"]
    assert (t["solved"], t["solved_under_noise"]) == (2, 1)
    assert runs[0].to_dict()["solved_under_noise"] is True
    noise_free = ExperimentPlan(modes=("situational",), runs=1)
    assert load_run(noise_free, "situational", 1, tmp_path / "kept").solved_under_noise is None
    assert "solved_under_noise" not in mode_table(noise_free, finished)["situational"]
    text = _robust_text(plan.to_dict())
    assert "first solution and 2 generation(s) more" in text and "3 episode(s)" in text
    assert _robust_text(noise_free.to_dict()) == ""
    assert "lifetime" not in text
    assert "(`--fitness-memory lifetime`)" in _robust_text(replace(plan, fitness_memory="lifetime").to_dict())
    assert "(`--fitness-memory archive`)" in _robust_text(replace(plan, fitness_memory="archive").to_dict())


def test_more_generations_after_the_solution_extend_an_experiment_fewer_are_refused(tmp_path):
    ExperimentPlan(**{**SMALL, "after_solved": 50}).save_or_check(tmp_path)
    ExperimentPlan(**{**SMALL, "after_solved": 80}).save_or_check(tmp_path)  # continues the runs
    assert ExperimentPlan.load(tmp_path).after_solved == 80
    with pytest.raises(ValueError, match="after_solved"):
        ExperimentPlan(**{**SMALL, "after_solved": 60}).save_or_check(tmp_path)


def test_the_robust_count_needs_eight_of_ten_noisy_sequential_successes_on_every_map():
    def transfer(plus: float, asym: float) -> dict:
        return {"plus": {"sequential_noisy": {"success_fraction": plus}},
                "asymmetric_plus": {"sequential_noisy": {"success_fraction": asym}}}

    eight_of_ten = float(np.mean([True] * 8 + [False] * 2))
    assert robust_on_every_map(transfer(eight_of_ten, 1.0))
    assert not robust_on_every_map(transfer(1.0, 0.7)) and not robust_on_every_map(transfer(0.7, 0.9))



def test_published_reports_are_what_the_report_renders_today():
    """Every results page's results.md is the markdown of its results.json as the code renders it now, so a change
    of the report (a new line, a new count) reaches the published pages (re-render them with `markdown`)."""
    from mahn_evo.experiment.report import markdown

    pages = sorted((Path(__file__).resolve().parents[2] / "docs" / "results").glob("*/results.json"))
    assert len(pages) >= 10
    stale = [p.parent.name for p in pages
             if markdown(json.loads(p.read_text())) != (p.parent / "results.md").read_text()]
    assert not stale, f"results.md differs from what its results.json renders to today: {stale}"
