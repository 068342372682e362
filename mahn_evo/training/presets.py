"""Named configurations: the original system as its code ran, and as its paper describes it.

A preset sets the fields that differ between readings of the original (initial population, module evaluation,
CPPN activation, NEAT rules); everything else keeps mahn's defaults, and explicit flags or a --config file still
override it.  docs/original-system.md lists where each value comes from.

- ``iros2011-code``: what the C# code (jimmytommy/AgentSimulator_v1_0) does: the seed genome with its Multiply
  modules dead (ModuleOutputNeuron returns 0 in the recursive pass), species tried in Hashtable order
  (Population.cs), the sticky stagnation flag with the champion's pardon (EvolutionAlgorithm.cs), compatibility
  weight coefficient 0.05 on the sum of weight differences (the experiment's NEAT parameters).
- ``iros2011-paper``: what the paper's text says where it differs from the code: "minimal CPPNs with random
  weights" as the start, compatibility weight coefficient 0.1; the code's rules elsewhere.
- ``iros2011-multistep``: the code's NEAT rules and seed genome, with the CPPN activated by the relaxation path
  its substrate code keeps as a comment (``MultipleSteps``, :mod:`mahn_evo.cppn.relax`), which makes the seed's
  Multiply modules live.  The paper's runs may have used it; the screen (docs/results/screen/) found it the best
  faithful configuration, so the full experiment uses it.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .config import EvolutionConfig

PRESETS: dict[str, dict[str, Any]] = {
    "iros2011-code": {
        "init": "iros2011", "evaluate_modules": False, "cppn_activation": "recursive",
        "neat": {"species_order": "random", "stagnation_rule": "sticky", "weight_coefficient": 0.05},
    },
    "iros2011-multistep": {
        "init": "iros2011", "evaluate_modules": True, "cppn_activation": "relax",
        "neat": {"species_order": "random", "stagnation_rule": "sticky", "weight_coefficient": 0.05},
    },
    "iros2011-paper": {
        "init": "minimal", "evaluate_modules": True, "cppn_activation": "recursive",
        "neat": {"species_order": "random", "stagnation_rule": "sticky", "weight_coefficient": 0.1},
    },
}


def preset_fields(name: str) -> Mapping[str, Any]:
    """The fields preset `name` sets (a ValueError naming the known presets otherwise)."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown preset {name!r}; known: {sorted(PRESETS)}") from None


def apply_preset(config: EvolutionConfig, name: str) -> EvolutionConfig:
    """`config` with the fields of preset `name` set (NEAT settings merged into its own)."""
    fields = dict(preset_fields(name))
    neat = {**config.neat.to_dict(), **fields.pop("neat", {})}
    return EvolutionConfig.from_mapping({**config.to_dict(), **fields, "neat": neat})
