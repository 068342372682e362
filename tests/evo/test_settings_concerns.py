"""NeatSettings: one validated record per concern behind the one flat [neat] table."""
import dataclasses
import json
import pickle

import pytest

from mahn_evo.neat import (
    CppnSettings,
    InitialisationSettings,
    MutationSettings,
    NeatSettings,
    ReproductionSettings,
    SelectionSettings,
    SpeciationSettings,
)
from mahn_evo.neat.settings import CONCERN_OF, CONCERNS

RECORDS = (ReproductionSettings, SelectionSettings, MutationSettings, SpeciationSettings, InitialisationSettings,
           CppnSettings)


def test_every_flat_key_lives_in_exactly_one_concern():
    names = [f.name for cls in RECORDS for f in dataclasses.fields(cls)]
    assert len(names) == len(set(names)) == len(CONCERN_OF)
    assert tuple(CONCERNS.values()) == RECORDS
    assert set(NeatSettings().to_dict()) == set(names)


def test_flat_keys_reach_their_record_and_read_back_flat():
    s = NeatSettings(population_size=60, weight_limit=2.0, tie_break="oldest", species_order="random",
                     initial_weight_range=1.0)
    assert s.reproduction.population_size == s.population_size == 60
    assert s.mutation.weight_limit == s.weight_limit == 2.0
    assert s.selection.tie_break == "oldest" and s.speciation.species_order == "random"
    assert s.initialisation.initial_weight_range == 1.0
    back = NeatSettings.from_mapping(json.loads(json.dumps(s.to_dict())))
    assert back == s and hash(back) == hash(s) and pickle.loads(pickle.dumps(s)) == s
    assert s.replace(weight_limit=1.0).mutation.weight_limit == 1.0


def test_each_record_validates_its_own_fields_with_the_flat_name():
    with pytest.raises(ValueError, match=r"NeatSettings\.weight_limit"):
        MutationSettings(weight_limit=0.0)
    with pytest.raises(ValueError, match=r"NeatSettings\.tie_break"):
        SelectionSettings(tie_break="random")
    with pytest.raises(ValueError, match=r"NeatSettings\.threshold_floor"):
        SpeciationSettings(threshold_floor=0)
    with pytest.raises(ValueError, match=r"NeatSettings\.population_size"):
        ReproductionSettings(population_size=1)
    with pytest.raises(ValueError, match=r"NeatSettings\.initial_weight_jitter"):
        InitialisationSettings(initial_weight_jitter=-1.0)
    with pytest.raises(ValueError, match=r"NeatSettings\.evaluate_modules"):
        CppnSettings(evaluate_modules=1)  # type: ignore[arg-type]
    # a rule across concerns is NeatSettings' own: the species range against the population size
    with pytest.raises(ValueError, match=r"species_count_max: must not exceed population_size"):
        NeatSettings(population_size=10, species_count_max=11)
    assert NeatSettings(population_size=100).species_target_range == (8, 10)


def test_records_can_be_given_whole_but_not_twice_and_unknown_keys_are_named():
    m = MutationSettings(add_node_probability=0.5)
    s = NeatSettings(mutation=m, population_size=20)
    assert s.mutation is m and dataclasses.replace(s, mutation=MutationSettings()).add_node_probability == 0.01
    with pytest.raises(TypeError, match=r"\['add_node_probability'\] given both flat and inside mutation"):
        NeatSettings(mutation=m, add_node_probability=0.1)
    with pytest.raises(TypeError, match="NeatSettings.mutation: must be a MutationSettings"):
        NeatSettings(mutation=SelectionSettings())
    with pytest.raises(TypeError, match="unknown setting.*populaton_size"):
        NeatSettings(populaton_size=5)
    with pytest.raises(ValueError, match="unknown setting.*populaton_size"):
        NeatSettings.from_mapping({"populaton_size": 5})
    with pytest.raises(AttributeError, match="populaton_size"):
        _ = NeatSettings().populaton_size
