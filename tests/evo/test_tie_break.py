"""Equal fitness within a species: youngest first (SharpNEAT 1.0) or oldest first (mahn 0.1), and old states."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mahn_evo.neat import NeatSettings, Population

S = NeatSettings(population_size=40, initial_compatibility_threshold=100.0)  # one species: ties are species-wide


@pytest.mark.parametrize("rule", ["youngest", "oldest"])
def test_on_a_plateau_elites_are_the_newest_or_the_first_born(rule):
    pop = Population.create(S.replace(tie_break=rule), seed=5, kind="iros2011", n_inputs=6)
    flat = np.full(40, 3.0)
    for _ in range(4):
        pop.tell(flat)
    born = pop.to_dict()["born"]
    elites = [b for b in born if b < pop.generation]
    assert len(elites) == 8  # floor(0.2 * 40)
    if rule == "youngest":
        assert elites == [pop.generation - 1] * 8  # last generation's offspring replaced the old elites
    else:
        assert elites == [0] * 8  # the initial genomes stay elites for ever


def test_fitness_still_comes_first():
    pop = Population.create(S, seed=5, kind="iros2011", n_inputs=6)
    pop.tell(np.full(40, 3.0))
    f = np.full(40, 3.0)
    f[0] = 4.0  # an elite (born in generation 0) is fitter than every newer genome
    first = pop.genomes[0]
    pop.tell(f)
    assert pop.genomes[0] == first and pop.to_dict()["born"][0] == 0


def test_born_is_saved_and_checked():
    pop = Population.create(S, seed=5, kind="iros2011", n_inputs=6)
    for _ in range(2):
        pop.tell(np.arange(40, dtype=float) % 3)
    d = json.loads(json.dumps(pop.to_dict()))
    assert Population.from_dict(d).to_dict() == d
    bad = {**d, "born": d["born"][:-1]}
    with pytest.raises(ValueError, match="born"):
        Population.from_dict(bad)
    no_ages = {k: v for k, v in d.items() if k != "born"}
    with pytest.raises(ValueError, match="missing.*born"):
        Population.from_dict(no_ages)  # the current format must have them
    with pytest.raises(ValueError, match="no genome ages.*youngest"):
        Population.from_dict({**no_ages, "version": 1})  # format 1 may lack them, but only under the old rules
    no_parents = {k: v for k, v in d.items() if k != "parents"}
    with pytest.raises(ValueError, match="no parent species.*respeciate_parents_first"):
        Population.from_dict({**no_parents, "version": 1})


def test_a_state_saved_before_the_settings_existed_continues_with_the_old_rules():
    pop = Population.create(S.replace(tie_break="oldest", respeciate_parents_first=False), seed=5,
                            kind="iros2011", n_inputs=6)
    pop.tell(np.full(40, 1.0))
    d = json.loads(json.dumps(pop.to_dict()))
    legacy = {k: v for k, v in d.items() if k not in ("born", "parents")} | {"version": 1}
    legacy["settings"] = {k: v for k, v in d["settings"].items() if k not in ("tie_break", "respeciate_parents_first")}
    old, new = Population.from_dict(legacy), Population.from_dict(d)
    assert old.settings.tie_break == "oldest" and not old.settings.respeciate_parents_first
    f = np.random.default_rng(0).integers(0, 3, 40).astype(float)
    old.tell(f)
    new.tell(f)
    assert old.genomes == new.genomes


def test_bad_tie_break_is_refused():
    with pytest.raises(ValueError, match="tie_break"):
        NeatSettings(tie_break="random")
