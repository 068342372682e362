"""Map-branch training (`--map-branch B`): keyed episodes on plus variants whose side arms leave the top arm above
the crossing, so the crossing is not symmetric."""
from __future__ import annotations

import numpy as np
import pytest

from mahn_envs.core import BatchSim
from mahn_envs.maps import load_map
from mahn_envs.maps.variants import HIGH, LOW, PLUS_ARM, plus_variant, spread_variant
from mahn_evo.cli import build_parser, experiment_plan
from mahn_evo.experiment.report import _robust_text
from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.presets import apply_preset
from mahn_evo.training.trainer import Trainer


def _side_openings(world) -> tuple[float, float]:
    """The y of the lower wall of the left and of the right arm (where each side arm leaves the top arm)."""
    walls = np.asarray(world.walls)
    horizontal = walls[np.isclose(walls[:, 1], walls[:, 3])]
    left = horizontal[(np.minimum(horizontal[:, 0], horizontal[:, 2]) < LOW - 1.0)][:, 1].min()
    right = horizontal[(np.maximum(horizontal[:, 0], horizontal[:, 2]) > HIGH + 1.0)][:, 1].min()
    return float(left), float(right)


def test_the_test_maps_geometry_is_a_branch_variant():
    """The asymmetric plus is the plus family's member with left 48.43, top and right 118.11 and the right arm 77.5
    above the crossing: same walls (as segments) and the same POIs up to the plus map's 0.5 cm POI offset."""
    v, asym = plus_variant(48.43, 118.11, 118.11, right_offset=77.5), load_map("asymmetric_plus")
    def segments(w):
        return np.array(sorted(tuple(np.ravel(sorted([tuple(s[:2]), tuple(s[2:])]))) for s in np.asarray(w.walls)))
    assert np.allclose(segments(v), segments(asym), atol=1e-6)
    assert np.allclose(v.pois, asym.pois, atol=0.51)


def test_branch_offsets_are_drawn_per_key_within_the_bound_and_keep_the_arm_lengths():
    seen = []
    for key in range(40):
        w = spread_variant(2, key, 0.0, 30.0)
        left, right = _side_openings(w)
        assert 0.0 <= left - LOW <= 30.0 + 1e-9 and 0.0 <= right - LOW <= 30.0 + 1e-9
        xmin, _, xmax, ymax = w.bounds
        assert np.allclose([LOW - xmin, ymax - HIGH, xmax - HIGH], PLUS_ARM)  # lengths: the plus map's
        seen.append((left, right))
    assert len(set(seen)) == 40 and spread_variant(2, 3, 0.0, 30.0).name == spread_variant(2, 3, 0.0, 30.0).name
    # with a spread too, the lengths are drawn first: a spread-only run's lengths do not change
    assert spread_variant(2, 3, 0.3, 20.0).bounds == spread_variant(2, 3, 0.3).bounds
    with pytest.raises(ValueError, match="map_branch must be"):
        spread_variant(0, 0, 0.0, 60.0)  # beyond the top arm less one corridor width
    with pytest.raises(ValueError, match="map_branch must be"):
        spread_variant(0, 0, 0.3, 30.0)  # the shortest top arm of spread 0.3 leaves room for 25.6 cm only
    with pytest.raises(ValueError, match="offset must be in"):
        plus_variant(78.74, 78.74, 78.74, left_offset=-1.0)


def test_keyed_episodes_are_played_on_branch_variants_and_the_clean_one_on_plus(tmp_path):
    cfg = apply_preset(EvolutionConfig(seed=4, init="minimal"), "hardened").with_overrides(
        pop=8, robust_from="start", robust_delay=0, map_branch=40.0)
    genomes = Trainer(cfg, tmp_path).population.ask()
    ev = TeamEvaluator(cfg.evaluation)
    ctrl = ev.decode(genomes)
    fitness, _ = ev.score(ctrl, generation=1)
    n = len(genomes)
    expected = np.zeros(n)
    for key in ev.episode_keys(1):
        sim = BatchSim(spread_variant(cfg.seed, key, 0.0, 40.0), n, cfg.task)
        expected += sim.run_controllers(ctrl, seed=cfg.seed, episode_keys=np.full(n, key, dtype=np.int64)).fitness
    expected += BatchSim("plus", n, cfg.task.without_noise()).run_controllers(
        ctrl, seed=cfg.seed, episode_keys=np.zeros(n, dtype=np.int64)).fitness
    assert fitness == pytest.approx(expected / 4, abs=1e-12)
    plain, _ = TeamEvaluator(EvaluationSettings(**{**cfg.evaluation.__dict__, "map_branch": 0.0})).score(ctrl, 1)
    assert not np.allclose(plain, fitness)


def test_plain_episodes_keep_the_first_keyed_episodes_of_each_generation_on_plus(tmp_path):
    cfg = apply_preset(EvolutionConfig(seed=4, init="minimal"), "hardened").with_overrides(
        pop=8, robust_from="start", robust_delay=0, map_branch=20.0, plain_episodes=1)
    genomes = Trainer(cfg, tmp_path).population.ask()
    ev = TeamEvaluator(cfg.evaluation)
    ctrl = ev.decode(genomes)
    n = len(genomes)
    for generation in (0, 5):
        fitness, _ = ev.score(ctrl, generation=generation)
        keys = ev.episode_keys(generation)
        assert keys[0] % cfg.episodes == 0
        expected = np.zeros(n)
        for i, key in enumerate(keys):
            world = "plus" if i == 0 else spread_variant(cfg.seed, key, 0.0, 20.0)
            expected += BatchSim(world, n, cfg.task).run_controllers(
                ctrl, seed=cfg.seed, episode_keys=np.full(n, key, dtype=np.int64)).fitness
        expected += BatchSim("plus", n, cfg.task.without_noise()).run_controllers(
            ctrl, seed=cfg.seed, episode_keys=np.zeros(n, dtype=np.int64)).fitness
        assert fitness == pytest.approx(expected / 4, abs=1e-12)
    all_variants, _ = TeamEvaluator(EvaluationSettings(**{**cfg.evaluation.__dict__, "plain_episodes": 0})).score(
        ctrl, 5)
    assert not np.allclose(all_variants, ev.score(ctrl, 5)[0])
    with pytest.raises(ValueError, match="plain_episodes must be"):
        EvaluationSettings(episodes=3, map_branch=20.0, plain_episodes=4)
    with pytest.raises(ValueError, match="plain_episodes keeps"):
        EvaluationSettings(episodes=3, plain_episodes=1)
    assert cfg.noise_free_evaluation.plain_episodes == 0
    args = build_parser().parse_args(["experiment", "--preset", "hardened", "--map-branch", "20",
                                      "--plain-episodes", "1", "--after-solved", "250", "--out", "x"])
    plan = experiment_plan(args)
    assert plan.plain_episodes == 1 and plan.train_config("situational", 2).plain_episodes == 1
    assert "the first 1 on the map itself (`--plain-episodes 1`), the others on a plus variant" in _robust_text(
        plan.to_dict())


def test_the_branch_is_checked_kept_out_of_the_noise_free_phase_and_reaches_the_report():
    with pytest.raises(ValueError, match="map_branch must be"):
        EvaluationSettings(map_branch=-5.0)
    with pytest.raises(ValueError, match="needs map 'plus'"):
        EvaluationSettings(map="asymmetric_plus", map_branch=20.0)
    cfg = apply_preset(EvolutionConfig(), "hardened").with_overrides(map_branch=40.0)
    assert cfg.evaluation.map_branch == 40.0 and cfg.noise_free_evaluation.map_branch == 0.0
    assert EvolutionConfig.from_mapping(cfg.to_dict()).map_branch == 40.0
    args = build_parser().parse_args(["experiment", "--preset", "hardened", "--map-branch", "40",
                                      "--after-solved", "250", "--out", "x"])
    plan = experiment_plan(args)
    assert plan.map_branch == 40.0 and plan.train_config("situational", 2).map_branch == 40.0
    text = _robust_text(plan.to_dict())
    assert "side arms leaving the top arm [0, 40] cm above the crossing" in text
    assert "noise-free episode on the map itself" in text
    train = build_parser().parse_args(["train", "--preset", "hardened", "--map-branch", "25", "--out", "y"])
    assert train.map_branch == 25.0


def test_the_published_branch_experiment_is_the_documented_command():
    from pathlib import Path

    from mahn_evo.experiment.plan import ExperimentPlan

    published = ExperimentPlan.load(Path(__file__).parents[2] / "docs" / "results" / "experiment_harden_branch")
    args = build_parser().parse_args(["experiment", "--modes", "situational", "--runs", "15", "--seed", "1",
                                      "--preset", "hardened", "--map-branch", "40", "--after-solved", "250"])
    assert experiment_plan(args) == published


def test_the_published_branch_plain_experiment_is_the_documented_command():
    from pathlib import Path

    from mahn_evo.experiment.plan import ExperimentPlan

    page = Path(__file__).parents[2] / "docs" / "results" / "experiment_harden_branch_plain"
    published = ExperimentPlan.load(page)
    args = build_parser().parse_args(["experiment", "--modes", "situational", "--runs", "15", "--seed", "1",
                                      "--preset", "hardened", "--map-branch", "40", "--plain-episodes", "1",
                                      "--after-solved", "250"])
    assert experiment_plan(args) == published
    assert "--plain-episodes 1" in (page / "README.md").read_text()


def _branch_clean_run(seed: int = 7) -> EvolutionConfig:
    """A noise-free run scored on plus and one branch variant per generation (robust_from start, no noise)."""
    return EvolutionConfig(generations=6, seed=seed, episodes=2, map_branch=40.0, plain_episodes=1,
                           noise_draws="per_generation").with_overrides(pop=24)


def _branch_then_hardened(seed: int = 7, robust_delay: int = 2) -> EvolutionConfig:
    """The same noise-free phase as `_branch_clean_run` (noise_free_branch), then 2 noisy + 1 noise-free episodes."""
    cfg = EvolutionConfig(generations=6, seed=seed, episodes=2, noise_draws="per_generation",
                          noise_free_episode=True).with_overrides(pop=24).with_noise("generalization")
    return cfg.with_overrides(robust_from="first_solution", robust_delay=robust_delay, noise_free_branch=40.0)


def test_noise_free_branch_scores_the_noise_free_phase_on_plus_and_a_branch_variant():
    hard = _branch_then_hardened()
    clean = hard.noise_free_evaluation
    assert clean == _branch_clean_run().evaluation  # the noise-free branch run, field for field
    assert (clean.episodes, clean.map_branch, clean.plain_episodes, clean.noise_draws) == (2, 40.0, 1, "per_generation")
    assert clean.task == hard.task.without_noise() and hard.evaluation.map_branch == 0.0  # the robust phase: plus
    ev = TeamEvaluator(clean)
    assert ev.episode_keys(3) == [6, 7]  # generation 3: key 6 on plus, key 7 on its own branch variant
    assert ev._keyed_sim(6, 2).world is ev._sim(2).world
    assert ev._keyed_sim(7, 2).world.name == spread_variant(7, 7, 0.0, 40.0).name != "plus"
    assert EvolutionConfig.from_mapping(hard.to_dict()) == hard
    with pytest.raises(ValueError, match="needs robust_from 'first_solution'"):
        _branch_clean_run().with_overrides(noise_free_branch=40.0)
    with pytest.raises(ValueError, match="noise_free_branch is the map_branch of the noise-free phase"):
        hard.with_overrides(noise_free_branch=60.0)
    with pytest.raises(ValueError, match="noise_free_branch: map_branch draws variants of the plus map"):
        hard.with_overrides(map="asymmetric_plus")
    train = build_parser().parse_args(["train", "--preset", "hardened", "--noise-free-branch", "40", "--out", "y"])
    assert train.noise_free_branch == 40.0
    args = build_parser().parse_args(["experiment", "--preset", "hardened", "--noise-free-branch", "40",
                                      "--after-solved", "250", "--out", "x"])
    plan = experiment_plan(args)
    assert plan.noise_free_branch == 40.0 and plan.train_config("situational", 2).noise_free_branch == 40.0
    assert plan.train_config("situational", 2).noise_free_evaluation.map_branch == 40.0
    assert ("noise-free (on plus and on a plus variant with side arms leaving the top arm [0, 40] cm above the "
            "crossing, new each generation: `--noise-free-branch 40`) until a run's first solution") \
        in _robust_text(plan.to_dict())


def test_a_solved_noise_free_branch_run_resumed_into_a_robust_phase_is_the_fresh_run(tmp_path):
    """A screen's noise-free branch runs can be hardened: resumed before the robust phase, bit for bit the run the
    hardening configuration makes from the start."""
    solved_at, delay = 1, 2
    start = solved_at + delay + 1

    def declare_solved(t: Trainer) -> None:
        while t.generation <= solved_at:
            t.step()
        t.first_solved = solved_at

    fresh = Trainer(_branch_then_hardened(robust_delay=delay), tmp_path / "fresh")
    declare_solved(fresh)
    while fresh.generation < 6:
        fresh.step()
    clean = Trainer(_branch_clean_run(), tmp_path / "later")
    declare_solved(clean)
    while clean.generation < start:
        clean.step()
    clean.finish()
    later = Trainer(_branch_then_hardened(robust_delay=delay), tmp_path / "later", resume=True)
    assert later.first_solved == solved_at and later.generation == start
    while later.generation < 6:
        later.step()
    assert [r[:-1] for r in later.rows] == [r[:-1] for r in fresh.rows]
    assert later.rows[start - 1][1] - later.rows[start - 2][1] == 24 * 2  # plus and the branch variant
    assert later.rows[start][1] - later.rows[start - 1][1] == 24 * 2  # then the noisy episodes (as counted)


def test_one_sided_branches_never_open_both_sides_at_once():
    """branch_sides "one": a random side at the crossing, the other's opening wholly above it (the test map's kind
    of crossing), where "both" leaves overlapping openings in most variants."""
    width = HIGH - LOW
    sides, overlapping = set(), 0
    for key in range(60):
        left, right = (y - LOW for y in _side_openings(spread_variant(5, key, 0.0, 49.0, "one")))
        assert min(left, right) == pytest.approx(0.0, abs=1e-9) and width - 1e-9 <= max(left, right) <= 49.0 + 1e-9
        sides.add("left" if left > right else "right")
        both = [y - LOW for y in _side_openings(spread_variant(5, key, 0.0, 40.0))]
        overlapping += abs(both[0] - both[1]) < width
    assert sides == {"left", "right"} and overlapping >= 45  # "both": about 93 % of variants overlap
    # "both" draws what it always drew (the published branch runs reproduce)
    assert spread_variant(2, 3, 0.0, 30.0).name == spread_variant(2, 3, 0.0, 30.0, "both").name == \
        "plus_arms_78.74_78.74_78.74_branch_7.47_27.33"
    with pytest.raises(ValueError, match="must exceed the corridor width"):
        spread_variant(0, 0, 0.0, 25.0, "one")
    with pytest.raises(ValueError, match="branch_sides must be one of"):
        EvaluationSettings(map_branch=40.0, branch_sides="left")
    with pytest.raises(ValueError, match="needs map_branch > 0"):
        EvaluationSettings(branch_sides="one")
    ev = TeamEvaluator(EvaluationSettings(episodes=2, map_branch=49.0, branch_sides="one", plain_episodes=1,
                                          noise_draws="per_generation", seed=5))
    assert ev._keyed_sim(2 * 7 + 1, 2).world.name == spread_variant(5, 15, 0.0, 49.0, "one").name
    args = build_parser().parse_args(["experiment", "--preset", "hardened", "--map-branch", "49", "--branch-sides",
                                      "one", "--plain-episodes", "1", "--after-solved", "150", "--out", "x"])
    plan = experiment_plan(args)
    cfg = plan.train_config("situational", 16)
    assert (cfg.branch_sides, cfg.evaluation.branch_sides, cfg.noise_free_evaluation.branch_sides) == \
        ("one", "one", "both")
    assert "one side arm at the crossing and the other leaving the top arm [29.53, 49] cm above it" in _robust_text(
        plan.to_dict())


def test_one_short_branches_keep_each_post_as_far_from_home_as_on_plus():
    """branch_sides "one_short": the draws of "one" (same side, same offset), with the raised arm shorter by its
    offset, so its post is as far from the junction along the corridors as on plus and the far robot can still
    reach it by the signal; the arm at the crossing and the top arm keep their lengths."""
    plus_pois = load_map("plus").pois
    centre = (LOW + HIGH) / 2
    for key in range(20):
        one = spread_variant(5, key, 0.0, 49.0, "one")
        short = spread_variant(5, key, 0.0, 49.0, "one_short")
        assert _side_openings(one) == _side_openings(short)
        corridor = [abs(x - centre) + abs(y - centre) for x, y in short.pois]
        plain = [abs(x - centre) + abs(y - centre) for x, y in plus_pois]
        assert corridor == pytest.approx(plain, abs=1e-9)
        assert np.array_equal(short.pois[1], one.pois[1])  # the top arm is untouched
    with pytest.raises(ValueError, match="must exceed the corridor width"):
        spread_variant(0, 0, 0.0, 25.0, "one_short")
    plan = {"map_branch": 49.0, "branch_sides": "one_short", "noise": "generalization", "episodes": 3}
    assert "above it, shorter by that offset (`--map-branch 49 --branch-sides one_short`)" in _robust_text(
        {**experiment_plan(build_parser().parse_args(["experiment", "--out", "x"])).to_dict(), **plan})


def test_noise_free_branch_draws_its_variants_as_branch_sides_says_so_a_one_sided_screen_can_be_hardened():
    """A noise-free screen on plus and one one_short variant per generation (`--episodes 2 --map-branch 49
    --branch-sides one_short --plain-episodes 1 --noise-draws per_generation`) is the noise-free phase of the
    hardening plan with `--noise-free-branch 49` and the same branch sides: that plan hardens its folder."""
    parser = build_parser()
    screen = experiment_plan(parser.parse_args(
        "experiment --out x --modes situational --runs 2 --seed 1 --preset best-restarts --generations 300 "
        "--episodes 2 --map-branch 49 --branch-sides one_short --plain-episodes 1 --noise-draws per_generation"
        .split()))
    harden = experiment_plan(parser.parse_args(
        "experiment --out x --modes situational --runs 2 --seed 1 --preset best-restarts --generations 300 "
        "--noise generalization --episodes 3 --noise-draws per_generation --noise-free-episode --map-branch 49 "
        "--branch-sides one_short --plain-episodes 1 --sequential-episodes 1 --noise-free-branch 49 "
        "--robust-from first_solution --robust-delay 50 --after-solved 150 --fitness-memory lifetime".split()))
    clean = harden.train_config("situational", 1).noise_free_evaluation
    assert clean == screen.train_config("situational", 1).evaluation
    assert (clean.branch_sides, clean.map_branch, clean.episodes) == ("one_short", 49.0, 2)
    assert harden.hardens(screen)
    assert ("noise-free (on plus and on a plus variant with one side arm at the crossing and the other leaving the "
            "top arm [29.53, 49] cm above it, shorter by that offset, new each generation: `--noise-free-branch 49`)"
            in _robust_text(harden.to_dict()))
    # one-sided openings need an offset above the corridor width, in the noise-free phase too
    with pytest.raises(ValueError, match="noise_free_branch is the map_branch of the noise-free phase"):
        harden.train_config("situational", 1).with_overrides(noise_free_branch=20.0)
