"""Budget matching and aggregation of the comparison, on synthetic run directories (no training needed)."""
from __future__ import annotations

import json
import math

import pytest

from baselines.cli import main
from baselines.comparison.compare import SAMPLED_SOLVED_RATE, compare, evo_budget, evo_curve, rl_curve, sampled_curve
from baselines.io import read_csv, write_csv, write_json


def _rl_run(root, algo, seed, rows):
    d = root / f"{algo}_seed{seed}"
    write_json(d / "config.json", {"algo": algo, "seed": seed, "map": "plus"})
    write_csv(d / "eval_log.csv", ["steps", "fitness_plus", "solved_plus"],
              [{"steps": s, "fitness_plus": f, "solved_plus": int(v)} for s, f, v in rows])
    write_json(d / "summary.json", {})
    return d


def _evo_run(root, mode, seed, rows, solved=False):
    d = root / f"evo_{mode}_{seed}"
    write_csv(d / "log.csv", ["generation", "evaluations", "best_fitness", "solved"],
              [{"generation": g, "evaluations": e, "best_fitness": f, "solved": v} for g, (e, f, v) in enumerate(rows)])
    write_json(d / "summary.json", {"mode": mode, "seed": seed, "solved": solved})
    return d


def test_evo_budget_is_teams_times_ticks_times_robots(tmp_path) -> None:
    d = _evo_run(tmp_path, "situational", 0, [(100, 5.0, False), (200, 130.0, True)])
    c = evo_curve(d)
    assert c.method == "hyperneat_situational"
    assert list(c.budget) == [100 * 1364 * 3, 200 * 1364 * 3]
    assert evo_budget([d]) == 200 * 1364 * 3


def test_a_run_stopped_at_its_solution_keeps_it_at_larger_budgets(tmp_path) -> None:
    stopped = evo_curve(_evo_run(tmp_path, "situational", 0, [(100, 5.0, False), (200, 130.0, True)], solved=True))
    cut = evo_curve(_evo_run(tmp_path, "standard", 0, [(100, 5.0, False), (200, 7.0, False)]))
    far = 10 * 200 * 1364 * 3
    assert stopped.at(far) == (130.0, 1.0)  # stopped because it solved: still solved with more budget
    assert math.isnan(cut.at(far)[0])  # never given that budget: no claim


def test_best_so_far_and_step_lookup(tmp_path) -> None:
    c = rl_curve(_rl_run(tmp_path, "ppo", 0, [(0, 1.0, 0), (1000, 3.0, 0), (2000, 2.0, 0), (3000, 120.0, 1)]))
    assert list(c.fitness) == [1.0, 3.0, 3.0, 120.0]  # best so far, like evolution's champion
    assert c.at(1500) == (3.0, 0.0) and c.at(3000) == (120.0, 1.0)
    assert math.isnan(c.at(10_000)[0])  # beyond the run's budget: no claim


def test_compare_writes_table_plot_and_json(tmp_path) -> None:
    rl = [_rl_run(tmp_path, "ppo", s, [(0, 1.0, 0), (409_200, 2.0 + s, 0), (818_400, 3.0 + s, 0)]) for s in (0, 1)]
    evo = [_evo_run(tmp_path, "standard", 0, [(100, 10.0, 0), (200, 150.0, 1)]),
           _evo_run(tmp_path, "situational", 0, [(100, 110.0, "True"), (200, 150.0, "True")])]
    out = tmp_path / "results"
    payload = compare(rl, evo, out, points=5)
    for name in ("comparison.csv", "comparison.md", "comparison.json", "comparison.png"):
        assert (out / name).stat().st_size > 0
    table = {r["method"]: r for r in payload["table"]}
    assert table["ppo"]["runs"] == 2 and table["ppo"]["fitness_mean"] == pytest.approx(3.5)
    assert table["hyperneat_situational"]["solved_rate"] == 1.0
    assert table["hyperneat_situational"]["median_budget_to_solve"] == 100 * 1364 * 3
    rows = read_csv(out / "comparison.csv")
    assert {r["method"] for r in rows} == {"ppo", "hyperneat_standard", "hyperneat_situational"}
    assert json.loads((out / "comparison.json").read_text())["budgets"] == payload["budgets"]


def test_cli_compare_existing_runs_only(tmp_path, capsys) -> None:
    _rl_run(tmp_path, "dqn", 0, [(0, 1.0, 0), (5000, 2.0, 0)])
    evo = _evo_run(tmp_path, "standard", 1, [(10, 1.5, 0)])
    assert main(["compare", "--no-train", "--runs-dir", str(tmp_path), "--algos", "dqn", "--seeds", "0",
                 "--evo-runs", str(evo), "--out", str(tmp_path / "o")]) == 0
    assert "hyperneat_standard" in capsys.readouterr().out


def test_evo_log_missing_columns_is_named(tmp_path) -> None:
    d = tmp_path / "bad"
    write_csv(d / "log.csv", ["generation", "best_fitness"], [{"generation": 0, "best_fitness": 1}])
    with pytest.raises(ValueError, match="evaluations"):
        evo_curve(d)


def test_cli_compare_takes_lean_and_cmaes_runs_as_they_are(tmp_path, capsys) -> None:
    lean = _rl_run(tmp_path / "fair", "mappo_gru", 0, [(0, 1.0, 0), (130_944, 2.5, 0)])
    cma = _evo_run(tmp_path, "situational", 3, [(100, 4.0, 0)])
    write_json(cma / "summary.json", {"method": "cmaes_direct_situational", "mode": "situational", "seed": 3})
    assert main(["compare", "--no-train", "--algos", "--rl-runs", str(lean), "--evo-runs", str(cma),
                 "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "mappo_gru" in out and "cmaes_direct_situational" in out


def test_compute_matched_curves_use_cpu_seconds_and_hyperneat_seconds(tmp_path) -> None:
    rl = tmp_path / "ppo_ff_seed0"
    write_json(rl / "config.json", {"algo": "ppo_ff", "seed": 0, "map": "plus"})
    write_csv(rl / "eval_log.csv", ["steps", "cpu_seconds", "fitness_plus", "solved_plus"],
              [{"steps": 1000, "cpu_seconds": 2.0, "fitness_plus": 3.0, "solved_plus": 0},
               {"steps": 2000, "cpu_seconds": 5.0, "fitness_plus": 2.0, "solved_plus": 0}])
    evo = tmp_path / "evo"
    write_csv(evo / "log.csv", ["generation", "evaluations", "best_fitness", "solved", "seconds"],
              [{"generation": g, "evaluations": 100 * (g + 1), "best_fitness": f, "solved": v, "seconds": 1.5}
               for g, (f, v) in enumerate([(5.0, 0), (130.0, 1), (131.0, 1)])])
    write_json(evo / "summary.json", {"mode": "situational", "seed": 0, "solved": True})
    r, e = rl_curve(rl), evo_curve(evo)
    assert list(r.on_cpu().budget) == [2.0, 5.0] and list(r.on_cpu().fitness) == [3.0, 3.0]
    assert list(e.on_cpu().budget) == [1.5, 3.0, 4.5]  # per-generation seconds, summed
    assert e.on_cpu().at(3.0) == (130.0, 1.0)
    assert r.on_cpu().at(50.0) == (3.0, 0.0)  # a run that spent fewer seconds keeps its result at later seconds
    bare = _rl_run(tmp_path, "dqn", 0, [(0, 1.0, 0)])  # logs no seconds: no compute-matched curve
    assert rl_curve(bare).on_cpu() is None
    payload = compare([rl, bare], [evo], tmp_path / "out", points=4)
    assert (tmp_path / "out" / "comparison_cpu.png").stat().st_size > 0
    by_method = {c["method"]: c for c in payload["curves"]}
    assert by_method["ppo_ff"]["cpu_seconds"] == [2.0, 5.0] and by_method["dqn"]["cpu_seconds"] is None
    spent = {r["method"]: r["median_cpu_seconds"] for r in payload["table"]}
    assert spent == {"ppo_ff": 5, "dqn": "", "hyperneat_situational": 4}  # what each run spent in all, median over runs


def test_published_curves_join_a_comparison_as_they_were(tmp_path) -> None:
    evo = [_evo_run(tmp_path, "situational", s, [(100, 50.0, 0), (200, 150.0 + s, 1)], solved=True) for s in (1, 2)]
    first = compare([], evo, tmp_path / "first", points=4)
    rl = _rl_run(tmp_path, "ppo_ff", 0, [(0, 1.0, 0), (900_000, 4.0, 0)])
    assert main(["compare", "--no-train", "--algos", "--rl-runs", str(rl), "--published",
                 str(tmp_path / "first" / "comparison.json"), "--published-methods", "hyperneat_situational",
                 "--out", str(tmp_path / "second")]) == 0
    second = json.loads((tmp_path / "second" / "comparison.json").read_text())
    again = {r["method"]: r for r in second["table"]}
    assert again["hyperneat_situational"] == {r["method"]: r for r in first["table"]}["hyperneat_situational"]
    assert {c["method"] for c in second["curves"]} == {"ppo_ff", "hyperneat_situational"}
    assert all(c["holds_after_end"] for c in second["curves"] if c["method"] == "hyperneat_situational")
    with pytest.raises(ValueError, match="no curve of method"):
        from baselines.comparison.compare import published_curves
        published_curves(tmp_path / "first" / "comparison.json", ["cmaes_direct_standard"])
    (tmp_path / "bad.json").write_text('{"curves": [{"method": "x", "budget": [1, 2], "fitness": [1]}]}')
    with pytest.raises(ValueError, match="curve 0 is malformed|different or zero lengths"):
        published_curves(tmp_path / "bad.json")


def _lean_run(root, seed, eval_rows, train_rows):
    """A lean PPO run folder as `mahn-baselines lean` writes its logs: greedy evaluations and training updates."""
    d = root / f"ippo_gru_seed{seed}"
    write_json(d / "config.json", {"kind": "lean_config", "algo": "ippo_gru", "method": "ippo_gru", "seed": seed,
                                   "map": "plus"})
    write_csv(d / "eval_log.csv", ["steps", "cpu_seconds", "fitness_plus", "solved_plus"],
              [{"steps": s, "cpu_seconds": s / 1000, "fitness_plus": f, "solved_plus": 0} for s, f in eval_rows])
    write_csv(d / "train_log.csv", ["update", "steps", "cpu_seconds", "fitness_mean", "solved_rate"],
              [{"update": u + 1, "steps": s, "cpu_seconds": s / 1000, "fitness_mean": f, "solved_rate": r}
               for u, (s, f, r) in enumerate(train_rows)])
    return d


def test_a_lean_run_is_read_as_its_greedy_and_its_sampling_policy(tmp_path) -> None:
    run = _lean_run(tmp_path, 0, [(0, 2.0), (1000, 2.1), (2000, 2.0)],
                    [(1000, 9.0, 0.1), (2000, 15.0, SAMPLED_SOLVED_RATE), (3000, 12.0, 0.2)])
    c = sampled_curve(run)
    assert c is not None and c.method == "ippo_gru_sampled" and c.seed == 0
    assert list(c.budget) == [1000, 2000, 3000] and list(c.fitness) == [9.0, 15.0, 15.0]  # best so far
    assert list(c.solved) == [0.0, 1.0, 1.0]  # half of one update's episodes solved: solved from then on
    assert list(c.cpu) == [1.0, 2.0, 3.0]
    assert sampled_curve(_rl_run(tmp_path, "ppo", 0, [(0, 1.0, 0)])) is None  # an SB3 run: greedy only
    payload = compare([run], [], tmp_path / "out", points=4)
    table = {r["method"]: r for r in payload["table"]}
    assert table["ippo_gru"]["fitness_max"] == 2.1 and table["ippo_gru"]["solved_rate"] == 0.0
    assert table["ippo_gru_sampled"]["fitness_max"] == 15.0 and table["ippo_gru_sampled"]["solved_rate"] == 1.0
    write_csv(run / "train_log.csv", ["update", "steps"], [{"update": 1, "steps": 1000}])
    with pytest.raises(ValueError, match="fitness_mean"):
        sampled_curve(run)


def test_runs_that_end_within_a_generation_of_each_other_are_read_at_their_ends(tmp_path) -> None:
    """IPOP-CMA-ES runs end a few hundred teams short of 500,000: the grid's last budgets must not average over
    only the runs that ended last (two unsolved runs ending first, one solved run ending last: 1 of 3, not 1 of 1)."""
    ends = [(499_300, 60.0, False), (499_600, 61.0, False), (500_000, 150.0, True)]
    runs = [_evo_run(tmp_path, "situational", s, [(1000, 50.0, False), (end, fit, ok)], solved=False)
            for s, (end, fit, ok) in enumerate(ends)]
    payload = compare([], runs, tmp_path / "out", points=4)
    last = [r for r in read_csv(tmp_path / "out" / "comparison.csv")][-1]
    assert int(last["budget_robot_steps"]) == 500_000 * 1364 * 3 and last["runs"] == "3"
    assert float(last["solved_rate"]) == pytest.approx(1 / 3, abs=1e-4)
    assert payload["table"][0]["solved_rate"] == pytest.approx(0.333, abs=1e-3)
    assert math.isnan(evo_curve(runs[0]).at(499_300 * 1364 * 3 * 1.02)[0])  # well beyond its end: no claim


def test_a_method_keeps_its_colour_in_both_figures(tmp_path, monkeypatch) -> None:
    """The compute-matched figure holds fewer methods (published curves carry no seconds); colours given figure by
    figure gave a method two colours on one page. A greedy policy and its sampling policy share a colour."""
    from baselines.comparison import compare as module

    styles = module.method_styles({"hyperneat_situational", "ippo_gru", "ippo_gru_sampled", "ppo"})
    assert styles["ippo_gru"][0] == styles["ippo_gru_sampled"][0]
    assert styles["ippo_gru"][1] == "--" and styles["ippo_gru_sampled"][1] == "-" and styles["ppo"][1] == "-"
    assert len({styles[m][0] for m in ("hyperneat_situational", "ippo_gru", "ppo")}) == 3
    drawn = []
    real_plot = module.plot
    monkeypatch.setattr(module, "plot", lambda curves, budgets, path, **kw: (
        drawn.append(({c.method for c in curves}, kw["styles"])), real_plot(curves, budgets, path, **kw))[1])
    evo = [_evo_run(tmp_path, "situational", s, [(100, 50.0, 0), (200, 150.0 + s, 1)], solved=True) for s in (1, 2)]
    compare([], evo, tmp_path / "first", points=4)  # its curves carry no seconds once published
    run = _lean_run(tmp_path, 0, [(0, 2.0), (1000, 2.1)], [(1000, 9.0, 0.1), (2000, 15.0, 0.2)])
    from baselines.comparison.compare import published_curves

    drawn.clear()
    compare([run], [], tmp_path / "out", points=4,
            published=published_curves(tmp_path / "first" / "comparison.json", ["hyperneat_situational"]))
    (steps_methods, steps_styles), (cpu_methods, cpu_styles) = drawn
    assert cpu_methods == {"ippo_gru", "ippo_gru_sampled"} < steps_methods
    assert cpu_styles == steps_styles
