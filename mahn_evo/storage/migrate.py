"""The one path from older file formats to the current one.

Every file mahn writes for users to keep carries ``kind`` and ``version`` (see mahn_evo.storage.files).  When a format
changes, :data:`FORMAT_VERSION` goes up by one and one step function is added to :data:`STEPS`: it turns a document of
version v into one of version v + 1 for every kind.  Every reader calls :func:`upgrade` (through
mahn_evo.storage.files.read_versioned_json / read_checked_json, and Population.from_dict for a bare population state),
so an old run folder, champion or experiment reads as if written today, step by step, and the code after the reader
knows only the current format.  A file newer than the code is refused with both versions named.

The rule that keeps old runs reproducing: a key absent from a saved document means the default of its format
version.  So changing a default, like adding a key whose absence must mean something else than its default, needs a
version bump and a step that writes the value the old files ran with (tests/trainer/test_migrate.py pins the
defaults of the current version).

Version 1 -> 2 (mahn 0.2):
- NEAT settings (config.json's and a checkpoint's ``neat`` table, a checkpoint's population settings,
  experiment.json's NEAT overrides) without ``tie_break`` / ``respeciate_parents_first`` were run with the rules of
  mahn 0.1 (:data:`V1_CHANGED_NEAT_DEFAULTS`), whose defaults changed since.
- A population state without genome ages (``born``) or parent species (``parents``) was bred before they were kept:
  all genomes count as born in generation 0 and without parents, which continues it exactly under those old rules
  only (other rules are refused).  Without ``last_improvement`` the population's best never improved (0).
- A champion without ``map`` was evolved on ``plus``; without ``seed`` its seed is unknown (null).
- A checkpoint of version 1 may lack its content checksum (written before checksums existed); from version 2 on it
  must carry one (checked by mahn_evo.storage.files.read_checked_json before the upgrade).
- Version 2 writes every NEAT setting; version 1 left out five settings at their default (their default is what an
  absent key means, so nothing needs filling in).
"""
from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from typing import Any

#: The version of every file mahn writes now.
FORMAT_VERSION = 2

#: NEAT settings whose default changed after version-1 files were written, with the value a version-1 file without
#: them was run with (mahn 0.1's rules).
V1_CHANGED_NEAT_DEFAULTS: Mapping[str, Any] = {"tie_break": "oldest", "respeciate_parents_first": False}

#: The kind of a bare population state (mahn_evo.neat.population) inside a checkpoint, where its "format" key says so.
POPULATION_FORMAT = "mahn-neat-population"


def check_version(data: Mapping[str, Any], where: str) -> int:
    """The format version of a document read from ``where`` (a file name, or what the document is); one that is
    not a version this code knows, or newer than it, is a ValueError naming both versions."""
    version = data.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise ValueError(f"{where} has format version {version!r}, which no mahn release wrote (this mahn reads "
                         f"versions 1 to {FORMAT_VERSION})")
    if version > FORMAT_VERSION:
        raise ValueError(f"{where} has format version {version}, newer than this mahn reads (versions 1 to "
                         f"{FORMAT_VERSION}): it was written by a newer mahn release; update mahn to read it")
    return version


def upgrade(data: Mapping[str, Any], kind: str, where: str) -> dict[str, Any]:
    """``data`` (a document of ``kind`` with its ``version``) upgraded step by step to :data:`FORMAT_VERSION`.

    ``data`` is not changed; what cannot be upgraded faithfully is a ValueError naming ``where``.
    """
    version = check_version(data, where)
    out = copy.deepcopy(dict(data))
    for v in range(version, FORMAT_VERSION):
        out = STEPS[v](kind, out, where)
        out["version"] = v + 1
    return out


def upgrade_population(data: Mapping[str, Any], where: str = "the population state") -> dict[str, Any]:
    """A bare population state (Population.to_dict) upgraded to the current version."""
    return upgrade(data, POPULATION_FORMAT, where)


# ---------------------------------------------------------------------------------------------------- 1 -> 2
def _v1_neat(neat: Any) -> Any:
    """NEAT settings of a version-1 file with the values they were run with (not a mapping: left to the reader)."""
    return {**V1_CHANGED_NEAT_DEFAULTS, **neat} if isinstance(neat, Mapping) else neat


def _v1_config(config: Any) -> Any:
    if isinstance(config, dict):
        config["neat"] = _v1_neat(config.get("neat", {}))
    return config


def _v1_population(pop: dict[str, Any], where: str) -> dict[str, Any]:
    settings = _v1_neat(pop.get("settings", {}))
    pop["settings"] = settings
    genomes = pop.get("genomes")
    n = len(genomes) if isinstance(genomes, list) else 0
    if "born" not in pop:
        if settings.get("tie_break") != "oldest":
            raise ValueError(f"{where}: this state has no genome ages, so it cannot continue with tie_break "
                             f"{settings.get('tie_break')!r}")
        pop["born"] = [0] * n
    if "parents" not in pop:
        if settings.get("respeciate_parents_first") is not False:
            raise ValueError(f"{where}: this state has no parent species, so it cannot continue with "
                             "respeciate_parents_first")
        pop["parents"] = [[] for _ in range(n)]
    pop.setdefault("last_improvement", 0)
    return pop


def _v1_to_v2(kind: str, data: dict[str, Any], where: str) -> dict[str, Any]:
    if kind in ("config", "experiment"):
        _v1_config(data)
    elif kind == "checkpoint":
        _v1_config(data.get("config"))
        pop = data.get("population")
        if isinstance(pop, dict) and pop.get("version") == 1:
            data["population"] = _v1_population(pop, f"{where} (its population)")
            pop["version"] = 2
    elif kind == POPULATION_FORMAT:
        _v1_population(data, where)
    elif kind == "champion":
        data.setdefault("map", "plus")
        data.setdefault("seed", None)
    return data


#: STEPS[v] turns a document of version v into one of version v + 1: step(kind, data, where) -> data.
STEPS: dict[int, Callable[[str, dict[str, Any], str], dict[str, Any]]] = {1: _v1_to_v2}
