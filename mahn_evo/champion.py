"""Champion files: the best CPPN of a run and the team controllers it decodes to, as versioned JSON.

The controllers are stored decoded (plain arrays, see mahn_envs.controllers) so a champion can drive the
simulator, the PettingZoo env or real robots without the trainer; the CPPN is kept so it can be re-decoded,
inspected or evolved further.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mahn_envs.controllers import TeamControllers

from .files import atomic_write_json, read_versioned_json, versioned
from .neat.genome import Genome

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

    def to_dict(self) -> dict[str, Any]:
        return versioned(KIND, {
            "mode": self.mode, "fitness": self.fitness, "solved": self.solved, "generation": self.generation,
            "seed": self.seed, "map": self.map, "cppn": self.genome.to_dict(),
            "controllers": self.controllers.to_dict()})

    def save(self, path: str | Path) -> None:
        atomic_write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | Path) -> Champion:
        data = read_versioned_json(path, KIND)
        try:
            return cls(mode=data["mode"], fitness=float(data["fitness"]), solved=bool(data["solved"]),
                       generation=int(data["generation"]), genome=Genome.from_dict(data["cppn"]),
                       controllers=TeamControllers.from_dict(data["controllers"]), seed=data.get("seed"),
                       map=data.get("map", "plus"))
        except (KeyError, TypeError) as exc:
            raise ValueError(f"champion file {str(path)!r} is missing or has a malformed field: {exc}") from exc
