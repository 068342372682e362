"""Files of older format versions read through mahn_evo.storage.migrate: old runs resume to the log their own code
wrote, and a file newer than the code is refused naming the file and both versions.

The fixtures are run folders written by old commits (tests/trainer/fixtures/README.md says how)."""
import csv
import json
import shutil
from pathlib import Path

import pytest

from mahn_evo.cli import main
from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.neat import NeatSettings, Population
from mahn_evo.storage.files import CHECKSUM_KEY, atomic_write_json, read_checked_json, read_versioned_json, versioned
from mahn_evo.storage.migrate import FORMAT_VERSION, STEPS, upgrade
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer

FIXTURES = Path(__file__).parent / "fixtures"


def _log(path):
    with open(path, newline="") as f:
        return [{k: v for k, v in row.items() if k != "seconds"} for row in csv.DictReader(f)]


def _old_run(tmp_path, name):
    run = tmp_path / name
    shutil.copytree(FIXTURES / name, run)
    (run / "expected_log.csv").unlink()
    return run


@pytest.mark.parametrize("name", ["v1_10374b7", "v1_dafc457"])
def test_an_old_run_resumes_to_the_log_its_own_code_wrote(tmp_path, name):
    run = _old_run(tmp_path, name)
    assert json.loads((run / "checkpoint.json").read_text())["version"] == 1
    assert main(["train", "--out", str(run), "--resume", "--generations", "6", "--quiet"]) == 0
    assert _log(run / "log.csv") == _log(FIXTURES / name / "expected_log.csv")
    # written again in the current format: every NEAT setting, a checksum, the population's version
    ck = json.loads((run / "checkpoint.json").read_text())
    assert ck["version"] == ck["population"]["version"] == FORMAT_VERSION and CHECKSUM_KEY in ck
    assert set(ck["config"]["neat"]) == set(NeatSettings().to_dict())


def test_the_old_rules_matter_and_the_trainer_names_them(tmp_path):
    """The pre-tie-rule fixture ran with mahn 0.1's rules: today's rules give another log (so the test above would
    catch a migration that lost them), and resuming it with today's rules is refused, naming the setting."""
    fresh = tmp_path / "fresh"
    assert main(["train", "--out", str(fresh), "--generations", "6", "--pop", "30", "--seed", "7", "--quiet"]) == 0
    assert _log(fresh / "log.csv") != _log(FIXTURES / "v1_10374b7" / "expected_log.csv")
    run = _old_run(tmp_path, "v1_10374b7")
    asked = EvolutionConfig(generations=6, seed=7).with_overrides(pop=30)
    with pytest.raises(ValueError, match=r"neat.tie_break.*the run was made with .*neat.tie_break = 'oldest'"):
        Trainer(asked, run, resume=True)
    saved = EvolutionConfig.from_saved(read_versioned_json(run / "config.json", "config"))
    assert (saved.neat.tie_break, saved.neat.respeciate_parents_first) == ("oldest", False)


def test_a_file_newer_than_the_code_is_refused_naming_file_and_versions(tmp_path):
    newer = FORMAT_VERSION + 1
    path = tmp_path / "config.json"
    atomic_write_json(path, {**versioned("config", EvolutionConfig().to_dict()), "version": newer})
    with pytest.raises(ValueError, match=rf"config file .*config.json.* version {newer}, newer than this mahn reads "
                                         rf"\(versions 1 to {FORMAT_VERSION}\)"):
        read_versioned_json(path, "config")
    ck = tmp_path / "checkpoint.json"
    atomic_write_json(ck, {"kind": "checkpoint", "version": newer, CHECKSUM_KEY: "0" * 64})
    with pytest.raises(ValueError, match=rf"checkpoint.json.* version {newer}, newer"):
        read_checked_json(ck, "checkpoint")
    state = Population.create(NeatSettings(population_size=10), seed=1).to_dict()
    with pytest.raises(ValueError, match=rf"version {newer}, newer"):
        Population.from_dict({**state, "version": newer})
    with pytest.raises(ValueError, match="version 'x', which no mahn release wrote"):
        upgrade({"version": "x"}, "config", "config file 'c'")


def test_a_current_checkpoint_without_its_checksum_is_refused(tmp_path):
    run = _old_run(tmp_path, "v1_dafc457")
    assert main(["train", "--out", str(run), "--resume", "--generations", "4", "--quiet"]) == 0
    ck = json.loads((run / "checkpoint.json").read_text())
    del ck[CHECKSUM_KEY]
    (run / "checkpoint.json").write_text(json.dumps(ck))
    with pytest.raises(ValueError, match=f"checkpoint file .* is damaged: it has no {CHECKSUM_KEY} checksum"):
        read_checked_json(run / "checkpoint.json", "checkpoint")


def test_old_champions_and_experiment_plans_read_with_what_they_meant(tmp_path):
    champ = Champion.load(FIXTURES / "v1_10374b7" / "champion.json")
    assert (champ.map, champ.seed, champ.generation) == ("plus", 7, 0)
    data = json.loads((FIXTURES / "v1_10374b7" / "champion.json").read_text())
    del data["map"], data["seed"]  # the first champion files had neither
    (tmp_path / "c1.json").write_text(json.dumps(data))
    assert (Champion.load(tmp_path / "c1.json").map, Champion.load(tmp_path / "c1.json").seed) == ("plus", None)
    (tmp_path / "c2.json").write_text(json.dumps({**data, "version": FORMAT_VERSION}))
    with pytest.raises(ValueError, match="c2.json.*missing.*'(map|seed)'"):
        Champion.load(tmp_path / "c2.json")  # the current format has them
    plan = ExperimentPlan(runs=1, generations=2, population=20).to_dict()
    del plan["neat"]  # version-1 plans without the NEAT rules ran with mahn 0.1's
    atomic_write_json(tmp_path / "exp" / "experiment.json", {**versioned("experiment", plan), "version": 1})
    assert dict(ExperimentPlan.load(tmp_path / "exp").neat) == {"tie_break": "oldest",
                                                                "respeciate_parents_first": False}


def test_kinds_without_changes_pass_through_every_step():
    doc = {"kind": "lean_checkpoint", "version": 1, "a": [1, 2]}
    assert upgrade(doc, "lean_checkpoint", "x") == {**doc, "version": FORMAT_VERSION}
    assert doc["version"] == 1  # the input is not changed
    assert sorted(STEPS) == list(range(1, FORMAT_VERSION))


#: The defaults of format version 2.  An absent key of a saved file means its version's default
#: (mahn_evo.storage.migrate), so changing one of these needs FORMAT_VERSION + 1 and a step that writes the old value
#: into older files.
V2_NEAT_DEFAULTS = {
    "population_size": 500, "asexual_proportion": 0.5, "interspecies_mating_probability": 0.01,
    "disjoint_excess_recombine_probability": 0.1, "crossover_mutation_probability": 0.0, "elitism_proportion": 0.2,
    "selection_proportion": 0.8, "tie_break": "youngest", "fitness_floor": 1e-07, "stagnation_generations": 200,
    "stagnation_penalty": 0.01, "stagnation_rule": "recompute", "population_stagnation_generations": 0,
    "mutate_weights_probability": 0.96, "add_connection_probability": 0.03, "add_node_probability": 0.01,
    "weight_scheme_probabilities": [0.125, 0.125, 0.125, 0.5, 0.125], "weight_scheme_proportions": [0.5, 0.1, 0.1],
    "weight_jiggle": 0.05, "weight_limit": 1.5, "new_connection_weight_range": 0.375, "add_connection_attempts": 5,
    "allow_recurrent": True, "add_node_keeps_split_connection": True,
    "hidden_activations": ["bipolar_sigmoid", "gaussian", "abs", "sine"], "disjoint_coefficient": 1.0,
    "excess_coefficient": 1.0, "weight_coefficient": 0.05, "weight_difference_mean": False,
    "respeciate_parents_first": True, "species_order": "id", "initial_compatibility_threshold": 8.0,
    "species_count_min": None, "species_count_max": None, "threshold_delta_min": 0.1,
    "threshold_delta_proportion": 0.01, "threshold_delta_acceleration": 1.05, "threshold_delta_deceleration": 0.5,
    "threshold_floor": 0.01, "respeciation_complexity_change": 0.05, "initial_weight_jitter": 0.1,
    "initial_weight_range": 1.5, "evaluate_modules": False,
}
V2_TRAIN_DEFAULTS = {
    "mode": "situational", "generations": 1000, "seed": 0, "init": "iros2011", "map": "plus",
    "evaluate_modules": True, "cppn_activation": "recursive", "decision": "output", "symmetry": "none",
    "episodes": 1, "noise_draws": "fixed",
    "aggregate": "mean", "quantile": 0.25, "noise_free_episode": False, "map_spread": 0.0, "map_branch": 0.0,
    "branch_sides": "both", "plain_episodes": 0, "sequential_episodes": 0, "sequential_plain": 0,
    "noise_free_variants": 0,
    "robust_from": "start", "robust_delay": 0,
    "reflex_arc_from": "start",
    "fitness_memory": "generation",
    "noise_free_branch": 0.0,
    "diversity": 0.0, "diversity_k": 15, "restart_every": 0, "stop_when_solved": False,
    "after_solved": 0, "checkpoint_every": 1,
}


def test_the_defaults_of_the_current_format_are_pinned():
    assert FORMAT_VERSION == 2, "a new format version pins its own defaults here"
    assert NeatSettings().to_dict() == V2_NEAT_DEFAULTS
    config = EvolutionConfig().to_dict()
    assert {k: v for k, v in config.items() if k not in ("neat", "task")} == V2_TRAIN_DEFAULTS
