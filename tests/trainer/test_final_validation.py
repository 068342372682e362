"""Final validation (mahn_evo.evaluation.final_population): the final population scored on validation episodes."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mahn_evo.cli import main
from mahn_evo.evaluation.eval_champion import champion_policy
from mahn_evo.evaluation.final_population import (
    FAMILY_KEY,
    FAMILY_SEED,
    SEQUENTIAL_SEED,
    VALIDATION_KEY,
    final_population,
    validate_final_population,
)
from mahn_evo.evaluation.generalize import solutions_of
from mahn_evo.evaluation.protocols import sequential
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.hyperneat.substrate import team_reading
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.storage.files import atomic_write_checked_json, read_checked_json
from mahn_evo.training.champion import Champion

CHAMPION = Path(__file__).parents[2] / "docs" / "results" / "experiment" / "champions" / "situational_s012.json"


def _tiny_run(tmp_path: Path, name: str = "run") -> Path:
    out = tmp_path / name
    assert main(["train", "--preset", "best-restarts", "--generations", "1", "--pop", "12", "--seed", "5",
                 "--quiet", "--out", str(out)]) == 0
    return out


def _variants_run(out: Path) -> Path:
    """A one-generation run trained on one-sided plus variants (a family for the family stage)."""
    assert main(["train", "--preset", "best-restarts", "--generations", "1", "--pop", "12", "--seed", "5", "--quiet",
                 "--episodes", "2", "--map-branch", "49", "--branch-sides", "one_short", "--plain-episodes", "1",
                 "--noise-draws", "per_generation", "--out", str(out)]) == 0
    return out


def _plant(run: Path, champion: Path, index: int) -> None:
    """Put a published solution's CPPN into the run's final population at `index` (a real genome, decoded and
    played like any other)."""
    ckpt = run / "checkpoint.json"
    data = read_checked_json(ckpt, "checkpoint")
    data["population"]["genomes"][index] = json.loads(champion.read_text())["cppn"]
    atomic_write_checked_json(ckpt, "checkpoint", {k: v for k, v in data.items() if k not in ("kind", "version")})


def test_a_population_without_solutions_archives_nothing_and_says_so(tmp_path, capsys):
    run = _tiny_run(tmp_path)
    before = sorted(p.name for p in (run / "archive").glob("*")) if (run / "archive").exists() else []
    record = validate_final_population(run, episodes=2)
    assert record["chosen"] is None and record["teams"] == 3 * 12  # every reading of every team (symmetry best)
    assert record["first_key"] == VALIDATION_KEY and record["episodes"] == 2
    assert (sorted(p.name for p in (run / "archive").glob("*")) if (run / "archive").exists() else []) == before
    saved = json.loads((run / "final_validation.json").read_text())
    assert saved["kind"] == "final_validation" and saved["chosen"] is None
    assert main(["final-validation", str(run), "--episodes", "2"]) == 0
    assert "nothing archived" in capsys.readouterr().out


def test_the_best_noise_free_solution_of_the_population_is_archived(tmp_path):
    run = _tiny_run(tmp_path)
    _plant(run, CHAMPION, 7)
    record = validate_final_population(run, episodes=3)
    chosen = record["chosen"]
    assert chosen is not None and chosen["index"] == 7 and chosen["noise_free_solved"]
    assert chosen["solved_fraction"] == max(r["solved_fraction"] for r in record["top"] if r["noise_free_solved"])
    path = run / chosen["file"]
    assert path.name.startswith("solution_final_g") and path in solutions_of(run)
    champ = Champion.load(path)  # a valid champion file: its controllers are what its CPPN decodes to
    config, population = final_population(run)
    decoded = team_reading(TeamEvaluator(config.evaluation).decode([population.genomes[7]]), chosen["reading"])
    assert np.array_equal(champ.controllers.w_ih, decoded.w_ih[0])
    assert champ.solved and champ.generation == population.generation == 1
    # deterministic: the same record again
    assert validate_final_population(run, episodes=3, write=False) == record


def test_a_run_evolved_for_robots_is_validated_under_its_own_noise(tmp_path, capsys):
    """A run evolved with --noise robot is chosen under the robot noise (Khepera sensors, the reflex reading them);
    runs without a noise of their own keep the generalisation test's; --noise overrides both."""
    plain = _tiny_run(tmp_path)
    _plant(plain, CHAMPION, 7)
    robot = tmp_path / "robot"
    assert main(["train", "--preset", "best-restarts", "--generations", "1", "--pop", "12", "--seed", "5", "--quiet",
                 "--noise", "robot", "--out", str(robot)]) == 0
    _plant(robot, CHAMPION, 7)
    first = validate_final_population(plain, episodes=8, write=False)
    assert first["noise"] == "generalization"
    own = validate_final_population(robot, episodes=8, write=False)
    assert own["noise"] == "robot"
    # the same team, other episodes: the robot's sensors and reflex give it other scores
    row = {r["index"]: r for r in own["top"] if r["reading"] == "none"}[7]
    plain_row = {r["index"]: r for r in first["top"] if r["reading"] == "none"}[7]
    assert (row["solved_fraction"], row["mean_fitness"]) != (plain_row["solved_fraction"], plain_row["mean_fitness"])
    assert validate_final_population(robot, episodes=8, write=False, noise="generalization")["top"] == first["top"]
    assert main(["final-validation", str(plain), "--episodes", "2", "--noise", "robot"]) == 0
    assert json.loads((plain / "final_validation.json").read_text())["noise"] == "robot"
    with pytest.raises(ValueError, match="noise preset other than 'none'"):
        validate_final_population(plain, episodes=2, noise="none")


def test_bad_input_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="no checkpoint.json"):
        validate_final_population(tmp_path)
    run = _tiny_run(tmp_path)
    with pytest.raises(ValueError, match="episodes must be a positive integer"):
        validate_final_population(run, episodes=0)
    (run / "checkpoint.json").write_text((run / "checkpoint.json").read_text()[:-40])
    with pytest.raises(ValueError, match="checkpoint"):
        validate_final_population(run)
    assert main(["final-validation", str(run)]) == 2


ROBUST = Path(__file__).parents[2] / "docs" / "results" / "experiment_fresh_seeds_lifetime" / "champions" / \
    "situational_s029.json"


def test_the_sequential_stage_chooses_the_team_that_survives_the_real_world_protocol(tmp_path, capsys):
    """Two published solutions planted in a final population: s012 (faithful; 0-3 of 10 noisy sequential episodes
    in the published transfer test) and a lifetime-hardened s029 (10 of 10).  Every reading of both that solves
    the noise-free task played through 4 noisy sequential episodes, the stage must rank them by successes, archive
    the winner, and say so in the record."""
    run = _tiny_run(tmp_path)
    _plant(run, CHAMPION, 2)
    _plant(run, ROBUST, 7)
    plain = validate_final_population(run, episodes=3, write=False)
    solutions = [(r["index"], r["reading"]) for r in plain["top"] if r["noise_free_solved"]]
    assert {i for i, _ in solutions} == {2, 7}
    record = validate_final_population(run, episodes=3, sequential_teams=len(solutions), sequential_episodes=4)
    seq = record["sequential"]
    assert (seq["teams"], seq["episodes"], seq["first_seed"], seq["map"]) == (len(solutions), 4, SEQUENTIAL_SEED,
                                                                              "plus")
    ranking = seq["ranking"]
    # the candidates are the plain ranking's noise-free solutions, now ordered by sequential successes
    assert sorted((r["index"], r["reading"]) for r in ranking) == sorted(solutions)
    assert [r["sequential_successes"] for r in ranking] == sorted((r["sequential_successes"] for r in ranking),
                                                                  reverse=True)
    chosen = record["chosen"]
    assert chosen["index"] == 7 and chosen == {**ranking[0], "file": chosen["file"]}
    assert chosen["sequential_successes"] > max(r["sequential_successes"] for r in ranking if r["index"] == 2)
    # the archived file plays the same: its sequential episodes replayed from the file give the recorded count
    champ = Champion.load(run / chosen["file"])
    again = sequential(champion_policy(champ), map="plus", params=champ.task(task_params("generalization")),
                       episodes=4, seed=SEQUENTIAL_SEED)
    assert sum(again["solved"]) == chosen["sequential_successes"]
    saved = json.loads((run / "final_validation.json").read_text())
    assert saved["chosen"]["file"] == chosen["file"] and saved["sequential"]["ranking"][0]["index"] == 7
    assert main(["final-validation", str(run), "--episodes", "3", "--sequential", str(len(solutions)),
                 "--sequential-episodes", "4"]) == 0
    assert f"{chosen['sequential_successes']} of 4 sequential episodes" in capsys.readouterr().out
    with pytest.raises(ValueError, match="sequential_teams must be a non-negative integer"):
        validate_final_population(run, sequential_teams=-1)
    with pytest.raises(ValueError, match="sequential_episodes must be a positive integer"):
        validate_final_population(run, sequential_teams=1, sequential_episodes=0)


SEQ1 = Path(__file__).parents[2] / "docs" / "results" / "experiment_sequential_seeds_1_15" / "champions"


def _straight_and_turner(tmp_path: Path) -> tuple[Path, int]:
    """A run on one-sided variants with seq1's seed 3 pick (does not turn where one side opens alone) at index 2
    and seed 15's (turns) at index 7 of its final population, and how many (team, reading)s solve noise-free."""
    out = _variants_run(tmp_path / "variants")
    _plant(out, SEQ1 / "situational_s003.json", 2)
    _plant(out, SEQ1 / "situational_s015.json", 7)
    plain = validate_final_population(out, episodes=3, write=False)
    return out, sum(r["noise_free_solved"] for r in plain["top"])


def test_the_family_stage_chooses_the_team_that_turns_where_one_side_opens(tmp_path, capsys):
    """seq1's seed 3 pick (no turn where one side opens alone: 10 of 10 validation episodes on plus, 1 of 10 on the
    test map) and seed 15's (turns: 10 of 10 on both) planted in the final population of a run trained on one-sided
    variants: both succeed on plus (2 of 2 sequential episodes each); on the run's own variants only seed 15's does,
    and the family stage ranks by both."""
    out, teams = _straight_and_turner(tmp_path)
    record = validate_final_population(out, episodes=3, sequential_teams=teams, sequential_episodes=2,
                                       family_episodes=3)
    family = record["sequential"]["family"]
    assert (family["episodes"], family["first_key"], family["first_seed"]) == (3, FAMILY_KEY, FAMILY_SEED)
    assert len(family["maps"]) == 3 and all(name.startswith("plus_arms_") for name in family["maps"])
    ranking = record["sequential"]["ranking"]
    totals = [r["sequential_successes"] + r["family_successes"] for r in ranking]
    assert totals == sorted(totals, reverse=True)
    by_team = {i: max(r["family_successes"] for r in ranking if r["index"] == i) for i in (2, 7)}
    assert by_team[7] >= 2 and by_team[2] == 0
    assert record["chosen"]["index"] == 7
    # validating the same population again with other settings replaces its pick in the archive
    _plant(out, SEQ1 / "situational_s003.json", 7)
    again = validate_final_population(out, episodes=3, sequential_teams=1, sequential_episodes=1)
    picks = sorted(p.name for p in (out / "archive").glob("solution_final_*.json"))
    assert picks == [again["chosen"]["file"].split("/")[-1]]
    _plant(out, SEQ1 / "situational_s015.json", 7)
    assert main(["final-validation", str(out), "--episodes", "3", "--sequential", str(teams),
                 "--sequential-episodes", "2", "--family-episodes", "3"]) == 0
    assert f"and {record['chosen']['family_successes']} of 3 on its plus variants" in capsys.readouterr().out
    # a run trained on its map alone has no family; the family stage needs the sequential one
    plus_only = _tiny_run(tmp_path)
    with pytest.raises(ValueError, match="no family of plus variants"):
        validate_final_population(plus_only, sequential_teams=1, family_episodes=2)
    with pytest.raises(ValueError, match="give sequential_teams"):
        validate_final_population(out, family_episodes=2)
    with pytest.raises(ValueError, match="family_episodes must be a non-negative integer"):
        validate_final_population(out, sequential_teams=1, family_episodes=-1)


def test_the_batch_engine_plays_the_stage_in_the_compiled_core_and_chooses_as_pymunk_does(tmp_path, capsys):
    """engine "batch": seq1's seed 3 and seed 15 picks planted as above; every candidate's counts are the core's
    own protocol episodes (keys BATCH_SEQUENTIAL_KEY + e on plus, BATCH_FAMILY_KEY + i on the family's maps), the
    choice is seed 15's (as in pymunk), the record names the engine, and the CLI takes --engine."""
    from mahn_envs.core.sequential import play_sequential
    from mahn_envs.maps.variants import spread_variant
    from mahn_evo.evaluation.final_population import BATCH_FAMILY_KEY, BATCH_SEQUENTIAL_KEY

    out, teams = _straight_and_turner(tmp_path)
    record = validate_final_population(out, episodes=3, sequential_teams=teams, sequential_episodes=4,
                                       family_episodes=6, engine="batch")
    seq = record["sequential"]
    assert (seq["engine"], seq["first_key"], seq["family"]["first_episode_key"]) == \
        ("batch", BATCH_SEQUENTIAL_KEY, BATCH_FAMILY_KEY)
    config, population = final_population(out)
    worlds = [spread_variant(5, FAMILY_KEY + i, 0.0, 49.0, "one_short") for i in range(6)]
    noisy = task_params("generalization")
    for row in seq["ranking"]:
        team = team_reading(TeamEvaluator(config.evaluation).decode([population.genomes[row["index"]]]),
                            row["reading"]).team(0)
        on_plus = [play_sequential("plus", team, noisy, seed=5, episode_keys=[BATCH_SEQUENTIAL_KEY + e])
                   for e in range(4)]
        on_family = [play_sequential(w, team, noisy, seed=5, episode_keys=[BATCH_FAMILY_KEY + i])
                     for i, w in enumerate(worlds)]
        assert row["sequential_successes"] == sum(int(r.success[0]) for r in on_plus)
        assert row["family_successes"] == sum(int(r.success[0]) for r in on_family)
        assert row["family_stages"] == pytest.approx(sum(r.stages_completed[0] for r in on_family) / 54)
    assert record["chosen"]["index"] == 7
    by_team = {i: max(r["family_successes"] for r in seq["ranking"] if r["index"] == i) for i in (2, 7)}
    assert (by_team[7], by_team[2]) == (6, 2)  # the turner succeeds on every variant, the other on 2 of 6
    assert main(["final-validation", str(out), "--episodes", "3", "--sequential", str(teams), "--engine", "batch",
                 "--family-episodes", "6"]) == 0
    assert "of 6 on its plus variants" in capsys.readouterr().out
    with pytest.raises(ValueError, match="engine must be one of"):
        validate_final_population(out, sequential_teams=1, engine="box2d")


def test_general_from_final_validation_transfers_the_pick_not_the_archives_most_general(tmp_path):
    """A run whose archive holds seq1's seed 15 pick (all 25 noisy training episodes on plus in the published
    generalisation test) and whose final population holds seed 3's (20 of 25): the final validation can only pick
    seed 3's; the report's team of the run is the archive's most general (seed 15's) with general_from "archive"
    and the pick with "final_validation"."""
    import shutil
    from dataclasses import replace as replaced

    from mahn_evo.evaluation.generalize import generalize
    from mahn_evo.experiment.plan import ExperimentPlan
    from mahn_evo.experiment.table import RunRecord
    from mahn_evo.experiment.transfer import most_general

    out = _variants_run(tmp_path / "runs" / "situational_s005")
    (out / "archive").mkdir(exist_ok=True)
    shutil.copy(SEQ1 / "situational_s015.json", out / "archive" / "solution_g00000_i0001.json")
    _plant(out, SEQ1 / "situational_s003.json", 7)
    record = validate_final_population(out, episodes=3, sequential_teams=4, sequential_episodes=2, engine="batch")
    pick = record["chosen"]["file"].split("/")[-1]
    assert record["chosen"]["index"] == 7
    plan = ExperimentPlan(modes=("situational",), runs=1, seed=5, general_episodes=4, final_validation=3)
    rows = generalize(out, episodes=4, map="plus", seed=5)
    assert rows[0]["file"] == "solution_g00000_i0001.json" != pick  # the archive's most general is not the pick
    run = RunRecord(out.name, "situational", 5, out, True, 1, True, 0, 166.0, 1.0, np.zeros(1))
    assert most_general(plan, [run], "situational", log=lambda _: None)[0]["file"].endswith(rows[0]["file"])
    chosen = most_general(replaced(plan, general_from="final_validation"), [run], "situational",
                          log=lambda _: None)[0]
    assert chosen["file"].endswith(pick) and chosen["solution"]
    with pytest.raises(ValueError, match="give final_validation"):
        replaced(plan, final_validation=0, general_from="final_validation")
    with pytest.raises(ValueError, match="general_from must be one of"):
        replaced(plan, general_from="best")


HARDENED = Path(__file__).parents[2] / "docs" / "results" / "experiment_hardened_sequential" / "champions"


def test_general_rank_protocol_ranks_runs_by_their_picks_validation_successes(tmp_path):
    """Two runs whose final populations hold rob1000's seed 5 pick (passes plus, fails the variants) and seed 14's
    (passes both): ranked by the generalisation test on plus, seed 5's run comes first; by the final validation's
    sequential successes on the map and its variants (`general_rank="protocol"`), seed 14's."""
    from dataclasses import replace as replaced

    from mahn_evo.experiment.plan import ExperimentPlan
    from mahn_evo.experiment.table import RunRecord
    from mahn_evo.experiment.transfer import most_general

    runs, successes = [], {}
    for name in ("situational_s005", "situational_s014"):
        out = _variants_run(tmp_path / "runs" / name)
        _plant(out, HARDENED / f"{name}.json", 7)
        record = validate_final_population(out, episodes=4, sequential_teams=2, sequential_episodes=4,
                                           family_episodes=6, engine="batch")
        chosen = record["chosen"]
        assert chosen["index"] == 7
        successes[name] = chosen["sequential_successes"] + chosen["family_successes"]
        runs.append(RunRecord(name, "situational", 5, out, True, 1, True, 0, 166.0, 1.0, np.zeros(1)))
    assert successes["situational_s014"] > successes["situational_s005"]
    plan = ExperimentPlan(modes=("situational",), runs=1, seed=5, general_episodes=8, final_validation=4,
                          final_sequential=2, final_family=6, general_from="final_validation")
    by_general = most_general(plan, runs, "situational", log=lambda _: None)
    assert [e["run"] for e in by_general] == ["situational_s005", "situational_s014"]
    assert by_general[0]["general_solved_fraction"] > by_general[1]["general_solved_fraction"]
    assert all("validation_protocol_successes" not in e for e in by_general)
    by_protocol = most_general(replaced(plan, general_rank="protocol"), runs, "situational", log=lambda _: None)
    assert [e["run"] for e in by_protocol] == ["situational_s014", "situational_s005"]
    assert {e["run"]: e["validation_protocol_successes"] for e in by_protocol} == successes
    with pytest.raises(ValueError, match="general_rank must be one of"):
        replaced(plan, general_rank="best")
    with pytest.raises(ValueError, match="give general_from 'final_validation' and final_sequential"):
        replaced(plan, general_rank="protocol", final_sequential=0, final_family=0)
