"""Atomic result files: JSON and CSV are written to a temporary file in the same folder, then `os.replace`d,
so a crash or a concurrent reader never sees half a file (runs are resumed and compared from these files)."""
from __future__ import annotations

import csv
import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from mahn_evo.storage.files import atomic_write_text

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

    S = TypeVar("S", bound=DataclassInstance)


def _atomic_write_text(path: Path, text: str) -> None:
    atomic_write_text(path, text)  # one implementation for every file the project keeps


def write_json(path: str | Path, data: Any) -> None:
    _atomic_write_text(Path(path), json.dumps(data, indent=2, sort_keys=False) + "\n")


def read_json(path: str | Path) -> Any:
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def write_csv(path: str | Path, fieldnames: Sequence[str], rows: Iterable[Mapping[str, Any]]) -> None:
    import io

    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(fieldnames), lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: row.get(k, "") for k in fieldnames})
    _atomic_write_text(Path(path), buf.getvalue())


def read_csv(path: str | Path) -> list[dict[str, str]]:
    with open(path, encoding="utf-8", newline="") as f:
        return list(csv.DictReader(f))


def new_run_folder(out: Path, kind: str, config: Mapping[str, Any]) -> None:
    """Start a run in `out`: refuse a folder that already holds one (it must be resumed), then write its config."""
    from mahn_evo.storage.files import atomic_write_json, versioned

    if (out / "checkpoint.json").exists():
        raise ValueError(f"{str(out)!r} already holds a run (checkpoint.json); resume it or choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "config.json", versioned(kind, dict(config)))


def settings_from_dict(cls: type[S], d: Mapping[str, Any], what: str, derived: Iterable[str] = ()) -> S:
    """A settings record (a dataclass) from a saved mapping: its fields, skipping the file's own keys (kind,
    version) and `derived` ones (written for other readers, such as a run's method); any other key is a ValueError
    naming it and `what`, since a misspelt setting silently dropped would start a different run."""
    names = {f.name for f in fields(cls)}
    unknown = set(d) - names - {"kind", "version"} - set(derived)
    if unknown:
        raise ValueError(f"unknown {what} setting(s) {sorted(unknown)}; known: {sorted(names)}")
    return cls(**{k: v for k, v in d.items() if k in names})
