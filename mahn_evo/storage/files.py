"""Files users keep: plain JSON / CSV, written atomically, versioned, with clear errors on bad input.

Atomic = write a temporary file in the same folder, flush and fsync it, then os.replace: a crash or Ctrl-C
mid-write leaves the previous file intact, never a truncated one.
"""
from __future__ import annotations

import csv
import functools
import hashlib
import io
import json
import math
import os
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from mahn_envs.jsonfile import read_json_object

from .migrate import FORMAT_VERSION, check_version, upgrade

#: key of the content checksum in files that carry one (checkpoints): sha256 of the canonical JSON of the rest
CHECKSUM_KEY = "sha256"


@functools.lru_cache(maxsize=1)
def _default_mode() -> int:
    """The mode `open()` would give a new file (0666 minus the umask).  Read once: reading the umask means
    setting it, which other threads could see for an instant."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def atomic_write_text(path: str | Path, text: str) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(text)
            f.flush()
            os.fchmod(f.fileno(), _default_mode())  # mkstemp's 0600 would hide results from collaborators
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _jsonable(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def atomic_write_json(path: str | Path, data: Mapping[str, Any], compact: bool = False) -> None:
    """Indented for files people read; compact (C encoder, ~5x faster) for large machine files."""
    if compact:
        text = json.dumps(data, separators=(",", ":"), allow_nan=False, default=_jsonable)
    else:
        text = json.dumps(data, indent=1, allow_nan=False, default=_jsonable)
    atomic_write_text(path, text + "\n")


def atomic_write_csv(path: str | Path, header: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    atomic_write_text(path, buf.getvalue())


def read_versioned_json(path: str | Path, kind: str) -> dict[str, Any]:
    """Load a file we wrote, upgraded to the current format (mahn_evo.storage.migrate); a wrong kind, a version
    newer than this code or corrupt JSON is a ValueError naming it."""
    return upgrade(_check_kind(read_json_object(path, kind), path, kind), kind, _where(path, kind))


def _where(path: str | Path, kind: str) -> str:
    return f"{kind} file {str(path)!r}"


def _check_kind(data: dict[str, Any], path: str | Path, kind: str) -> dict[str, Any]:
    if data.get("kind") != kind:
        raise ValueError(f"{str(path)!r} is not a mahn {kind} file (kind={data.get('kind')!r})")
    return data


def versioned(kind: str, payload: Mapping[str, Any]) -> dict[str, Any]:
    return {"kind": kind, "version": FORMAT_VERSION, **payload}


def canonical_json(payload: Mapping[str, Any]) -> str:
    """The one text of a JSON document that its checksum covers: sorted keys, no spaces, ASCII.  Parsing it and
    writing it again gives the same text (Python floats round-trip exactly), so a reader can recompute it."""
    return json.dumps(payload, separators=(",", ":"), sort_keys=True, allow_nan=False, default=_jsonable)


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def atomic_write_checked_json(path: str | Path, kind: str, payload: Mapping[str, Any]) -> None:
    """A versioned machine file whose content carries its sha256, so one changed digit is caught on reading.

    The payload is serialised once (canonically) and the header spliced in front: the checksum costs one
    hash of the text, not a second serialisation.
    """
    reserved = {"kind", "version", CHECKSUM_KEY} & set(payload)
    if reserved:
        raise ValueError(f"{kind} payload must not use the reserved key(s) {sorted(reserved)}")
    body = canonical_json(payload)
    head = json.dumps({"kind": kind, "version": FORMAT_VERSION, CHECKSUM_KEY: _sha256(body)},
                      separators=(",", ":"))
    atomic_write_text(path, head[:-1] + ("}" if body == "{}" else "," + body[1:]) + "\n")


def read_checked_json(path: str | Path, kind: str) -> dict[str, Any]:
    """Load a file written by atomic_write_checked_json, upgraded to the current format (mahn_evo.storage.migrate); a
    content that does not match its checksum is a ValueError naming the file.  The checksum is checked on the file
    as written, before the upgrade; only version-1 files may lack it (written before checksums existed)."""
    data = _check_kind(read_json_object(path, kind), path, kind)
    version = check_version(data, _where(path, kind))
    expected = data.pop(CHECKSUM_KEY, None)
    if expected is None:
        if version >= 2:
            raise ValueError(f"{kind} file {str(path)!r} is damaged: it has no {CHECKSUM_KEY} checksum (edited by "
                             "hand?); restore it from a backup, or start the run again")
        return upgrade(data, kind, _where(path, kind))
    payload = {k: v for k, v in data.items() if k not in ("kind", "version")}
    try:
        actual = _sha256(canonical_json(payload))
    except (TypeError, ValueError) as exc:  # e.g. NaN written by hand
        raise ValueError(f"{kind} file {str(path)!r} is damaged: its content cannot be checked ({exc})") from exc
    if actual != expected:
        raise ValueError(f"{kind} file {str(path)!r} is damaged: its content does not match its {CHECKSUM_KEY} "
                         "checksum (edited by hand or corrupted on disk); restore it from a backup, or start the run "
                         "again")
    return upgrade(data, kind, _where(path, kind))


#: the temporary files of atomic_write_text: ".<name>.<random>.tmp"
_TEMP_GLOB = ".*.tmp"


def remove_stray_temp_files(folder: str | Path) -> list[Path]:
    """Delete the temporary files that atomic writes leave when a process is killed mid-write (the file they
    were replacing is intact).  Call only while no other process writes into `folder`."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    removed = []
    for p in folder.rglob(_TEMP_GLOB):
        if p.is_file() and p.name.count(".") >= 3:
            p.unlink(missing_ok=True)
            removed.append(p)
    return removed
