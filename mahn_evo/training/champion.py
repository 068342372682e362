"""Champion files: the best CPPN of a run and the team controllers it decodes to, as versioned JSON.

The controllers are stored decoded (plain arrays, see mahn_envs.policies.team_controllers) so a champion can drive the
simulator, the PettingZoo env or real robots without the trainer; the CPPN is kept so it can be re-decoded,
inspected or evolved further.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core import TaskParams
from mahn_envs.core.params import TEAM_FIELDS
from mahn_envs.policies.team_controllers import _FIELDS as CONTROLLER_FIELDS
from mahn_envs.policies.team_controllers import TeamControllers

from ..hyperneat.substrate import MODES
from ..neat.genome import Genome
from ..storage.files import atomic_write_json, read_versioned_json, versioned

KIND = "champion"


@dataclass
class Champion:
    mode: str
    fitness: float
    solved: bool
    generation: int
    genome: Genome
    controllers: TeamControllers
    seed: int | None = None
    map: str = "plus"
    #: the reflex variant the team was evolved with (TaskParams.reflex_arc); files before it have the original's
    reflex_arc: bool = False
    #: the input ceiling the team was evolved with (TaskParams.input_ceiling); files before it have the original's
    input_ceiling: float = 1.0

    def task(self, params: TaskParams | None = None) -> TaskParams:
        """`params` (default: the noise-free task) with this team's settings (TEAM_FIELDS: reflex variant, input
        ceiling).

        Why: a team evolved with the arcing reflex or an input ceiling meets other situations and inputs than the
        original's task gives it, so every evaluation of a champion (eval, generalisation, margins, transfer tests,
        deploy) drives it with the settings it was evolved with."""
        return (params if params is not None else TaskParams()).with_team_settings(self.team_settings())

    def team_settings(self) -> dict[str, Any]:
        """The task settings this team was evolved with (TEAM_FIELDS)."""
        return {name: getattr(self, name) for name in TEAM_FIELDS}

    def to_dict(self) -> dict[str, Any]:
        return versioned(KIND, {
            "mode": self.mode, "fitness": self.fitness, "solved": self.solved, "generation": self.generation,
            "seed": self.seed, "map": self.map, "reflex_arc": self.reflex_arc,
            "input_ceiling": self.input_ceiling, "cppn": self.genome.to_dict(),
            "controllers": self.controllers.to_dict()})

    def save(self, path: str | Path) -> None:
        atomic_write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | Path) -> Champion:
        """Read a champion file; a field that is missing, of the wrong type, an unknown mode, or controllers that
        are not what the file's CPPN decodes to are a ValueError naming the file."""
        data = read_versioned_json(path, KIND)
        where = f"champion file {str(path)!r}"
        if data.get("mode") not in MODES:
            raise ValueError(f"{where}: field 'mode' must be one of {MODES}, got {data.get('mode')!r}")
        try:
            champ = cls(mode=data["mode"], fitness=_number(data["fitness"], "fitness"),
                        solved=_flag(data["solved"], "solved"), generation=_count(data["generation"], "generation"),
                        genome=Genome.from_dict(data["cppn"]),
                        controllers=TeamControllers.from_dict(data["controllers"]), seed=data["seed"],
                        map=data["map"], reflex_arc=_flag(data.get("reflex_arc", False), "reflex_arc"),
                        input_ceiling=_number(data.get("input_ceiling", 1.0), "input_ceiling"))
            champ.task()  # the task's own check of the team settings (e.g. an input ceiling out of range)
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
            raise ValueError(f"{where} is missing or has a malformed field: {exc}") from exc
        _check_controllers_match_cppn(champ, where)
        return champ


def _number(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"field {field!r} must be a number, got {value!r}")
    return float(value)


def _flag(value: Any, field: str) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"field {field!r} must be true or false, got {value!r}")
    return value


def _count(value: Any, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise TypeError(f"field {field!r} must be a non-negative integer, got {value!r}")
    return value


#: the ways a run may have decoded its CPPNs (activation, evaluate_modules); a champion file does not say which.
#: Its team may also be a mirror reading of the decoded one (substrate.READINGS: symmetry "mirror" or "best").
DECODINGS = (("recursive", True), ("recursive", False), ("relax", True))


def champion_decoding(champ: Champion, where: str = "champion") -> tuple[str, bool, str]:
    """(CPPN activation, evaluate_modules, mirror reading) under which the champion's CPPN decodes to its stored
    controllers (the first of DECODINGS x READINGS that does), so its CPPN can be decoded again as its run did
    (e.g. to polish its weights).  Stored controllers that no decoding gives are a ValueError: the file mixes two
    teams or was edited."""
    from ..cppn import compile_genome
    from ..hyperneat.substrate import READINGS, decode_population, team_reading

    ctrl = champ.controllers
    if ctrl.batched or ctrl.mode != champ.mode:
        raise ValueError(f"{where}: its controllers are a {ctrl.mode} team{' batch' if ctrl.batched else ''}, but "
                         f"field 'mode' says {champ.mode!r}")
    for activation, modules in DECODINGS:
        try:
            painted = decode_population([compile_genome(champ.genome, activation, modules)], champ.mode,
                                        ctrl.n_robots)
        except (ValueError, IndexError, KeyError) as exc:
            raise ValueError(f"{where}: its CPPN cannot be decoded for mode {champ.mode!r} ({exc})") from exc
        for reading in READINGS:
            decoded = team_reading(painted, reading).team(0)
            if all(np.array_equal(getattr(decoded, f), getattr(ctrl, f)) for f in CONTROLLER_FIELDS):
                return activation, modules, reading
    raise ValueError(f"{where}: field 'controllers' does not match what field 'cppn' decodes to (the file was "
                     "edited, or mixes two teams)")


def _check_controllers_match_cppn(champ: Champion, where: str) -> None:
    """The stored controllers must be what the CPPN decodes to under one of the run settings that decide decoding
    (DECODINGS, READINGS), or the file mixes two teams or was edited."""
    champion_decoding(champ, where)
