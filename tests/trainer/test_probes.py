"""The map probes (mahn_evo.evaluation.probes): one change of the test map at a time, so a failure says which."""
import json
from pathlib import Path

import numpy as np
import pytest

from mahn_envs.maps import load_map
from mahn_envs.maps.variants import PLUS_ARM
from mahn_evo.cli import main
from mahn_evo.evaluation.probes import PROBES, Probe, all_posts, probe_summary, probe_team
from mahn_evo.training.champion import Champion

CHAMPIONS = Path(__file__).resolve().parents[2] / "docs/results/experiment_sequential_seeds_1_15/champions"
#: a first solution of the noise-free phase on plus and one-sided variants (seed 5, generation 189)
FIRST_TURNS_RIGHT = Path(__file__).resolve().parent / "fixtures" / "first_solution_turns_right_only.json"


def test_each_probe_changes_one_thing_of_plus():
    plus = load_map("plus")
    for probe in PROBES:
        world = probe.world()
        # home and starts are the task's, on every probe
        assert np.array_equal(world.home, plus.home) and np.array_equal(world.starts, plus.starts)
        arms = (probe.left, probe.top, probe.right)
        if probe.kind == "turn":  # one side raised (and shortened by its offset), the other at the crossing
            assert (probe.left_offset > 0) != (probe.right_offset > 0)
            assert probe.left + probe.left_offset == probe.right + probe.right_offset == probe.top == PLUS_ARM
        elif probe.kind == "length":
            assert probe.left_offset == probe.right_offset == 0 and arms != (PLUS_ARM,) * 3
        else:
            assert probe.builtin in ("plus", "asymmetric_plus")
    assert len({p.name for p in PROBES}) == len(PROBES)
    with pytest.raises(ValueError, match="probe kind must be one of"):
        Probe("x", "colour", "not a kind")


def test_a_team_that_waits_for_both_sides_fails_every_one_sided_opening_and_not_the_lengths():
    # seed 3's pick of experiment_sequential_seeds_1_15 (1 of 10 noisy sequential episodes on the test map):
    # every robot drives past an opening that has no partner on the other side, every arm length is fine
    rows = probe_team(Champion.load(CHAMPIONS / "situational_s003.json"), engine="kinematic",
                      names=("plus", "left_raised_30", "right_raised_45", "test_lengths", "asymmetric_plus"))
    result = {r["name"]: (r["success"], r["stages"]) for r in rows}
    assert result["plus"] == (True, 9) and result["test_lengths"] == (True, 9)
    assert result["left_raised_30"] == result["right_raised_45"] == result["asymmetric_plus"] == (False, 1)
    # the one robot that reached a post: all three went to the top arm's
    assert all(post == 1 for post, *_ in next(r for r in rows if r["name"] == "asymmetric_plus")["robots"])
    assert [r["posts"] for r in rows] == [3, 1, 1, 3, 1]
    text = probe_summary(rows)
    assert "turns where only the left side opens (every post reached): 0 of 1 probes, whole protocol in 0" in text
    assert "turns where only the right side opens (every post reached): 0 of 1 probes, whole protocol in 0" in text
    assert "other arm lengths: every post reached in 1 of 1 probes, whole protocol in 1" in text


def test_a_team_that_turns_but_misses_a_later_stage_counts_as_turning():
    # the noise-free branch screen's seed 5 first solution turns where the right side opens alone (every robot
    # reaches its post) and then misses one later stage: the turn counts, the protocol does not
    rows = probe_team(Champion.load(FIRST_TURNS_RIGHT), engine="kinematic", names=("right_raised_30",
                                                                                 "left_raised_30"))
    right, left = rows
    assert all_posts(right) and not right["success"] and right["stages"] == 8
    assert not all_posts(left)


def test_the_robust_team_turns_where_one_side_opens():
    rows = probe_team(Champion.load(CHAMPIONS / "situational_s015.json"), engine="kinematic",
                      names=("right_raised_30", "right_raised_45", "asymmetric_plus"))
    assert all(r["success"] and r["stages"] == 9 for r in rows)


def test_probe_cli(capsys):
    assert main(["probe", str(CHAMPIONS / "situational_s003.json"), "--engine", "kinematic", "--only", "plus",
                 "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["name"], r["success"], r["stages"], r["possible"]) for r in rows] == [("plus", True, 9, 9)]
    assert main(["probe", str(CHAMPIONS / "situational_s003.json"), "--only", "plus", "nowhere"]) == 2
    assert "unknown probe(s) ['nowhere']" in capsys.readouterr().err


def test_unknown_probe_names_are_refused_before_anything_runs():
    with pytest.raises(ValueError, match="unknown probe"):
        probe_team(Champion.load(CHAMPIONS / "situational_s003.json"), names=("left_raised_99",))
