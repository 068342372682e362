"""IQM, its bootstrap interval and Fisher's exact test, and their columns in the comparison table."""
from __future__ import annotations

import pytest

from baselines.comparison.stats import fisher_solved, iqm, iqm_ci


def test_iqm_is_the_mean_of_the_middle_half():
    assert iqm([1, 2, 3, 4, 5, 6, 7, 100]) == pytest.approx(4.5)  # the outlier does not count
    lo, hi = iqm_ci([1, 2, 3, 4, 5, 6, 7, 100])
    assert lo <= 4.5 <= hi and hi < 100
    assert iqm_ci([1, 2, 3, 4, 5], seed=1) == iqm_ci([1, 2, 3, 4, 5], seed=1)
    with pytest.raises(ValueError):
        iqm([])


def test_fisher_exact_on_solved_counts():
    # the published experiment: situational 10/15 against standard 0/15, p = 0.0002
    assert fisher_solved(10, 15, 0, 15) == pytest.approx(0.0002, abs=1e-6)
    assert fisher_solved(3, 5, 3, 5) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="valid count"):
        fisher_solved(6, 5, 0, 5)


def test_the_comparison_table_carries_the_statistics(tmp_path):
    from baselines.comparison.compare import REFERENCE_METHOD, compare
    from baselines.io import write_csv, write_json

    def evo(mode, seed, solved):
        d = tmp_path / f"{mode}_{seed}"
        write_csv(d / "log.csv", ["generation", "evaluations", "best_fitness", "solved"],
                  [{"generation": 0, "evaluations": 10, "best_fitness": 150.0 if solved else 50.0 + seed,
                    "solved": solved}])
        write_json(d / "summary.json", {"mode": mode, "seed": seed, "solved": solved})
        return d

    runs = [evo("situational", s, s < 4) for s in range(5)] + [evo("standard", s, False) for s in range(5)]
    table = {r["method"]: r for r in compare([], runs, tmp_path / "out", points=3)["table"]}
    key = f"fisher_p_vs_{REFERENCE_METHOD}"
    assert table["hyperneat_standard"][key] == pytest.approx(fisher_solved(0, 5, 4, 5), abs=1e-4)
    assert table["hyperneat_situational"][key] == ""
    assert table["hyperneat_situational"]["fitness_iqm"] == 150.0
