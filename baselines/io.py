"""Atomic result files: JSON and CSV are written to a temporary file in the same folder, then `os.replace`d,
so a crash or a concurrent reader never sees half a file (runs are resumed and compared from these files)."""
from __future__ import annotations

import csv
import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from mahn_evo.storage.files import atomic_write_text


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
