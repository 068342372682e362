"""Files users keep: plain JSON / CSV, written atomically, versioned, with clear errors on bad input.

Atomic = write a temporary file in the same folder, flush and fsync it, then os.replace: a crash or Ctrl-C
mid-write leaves the previous file intact, never a truncated one.
"""
from __future__ import annotations

import csv
import functools
import io
import json
import math
import os
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

FORMAT_VERSION = 1


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


def read_json_object(path: str | Path, what: str) -> dict[str, Any]:
    """A JSON object from a file; a missing file, corrupt JSON or another top level is a ValueError naming it."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"{what} file {str(path)!r} does not exist")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what} file {str(path)!r} is corrupt (not valid JSON: {exc})") from exc
    if not isinstance(data, dict):
        raise ValueError(f"{what} file {str(path)!r} must hold a JSON object")
    return data


def read_versioned_json(path: str | Path, kind: str) -> dict[str, Any]:
    """Load a file we wrote; a wrong kind, a newer/older version or corrupt JSON is a ValueError naming it."""
    return check_versioned(read_json_object(path, kind), path, kind)


def check_versioned(data: dict[str, Any], path: str | Path, kind: str) -> dict[str, Any]:
    if data.get("kind") != kind:
        raise ValueError(f"{str(path)!r} is not a mahn {kind} file (kind={data.get('kind')!r})")
    version = data.get("version")
    if version != FORMAT_VERSION:
        raise ValueError(f"{kind} file {str(path)!r} has format version {version!r}; this mahn reads version "
                         f"{FORMAT_VERSION}. Re-create it with a matching mahn release.")
    return data


def versioned(kind: str, payload: Mapping[str, Any]) -> dict[str, Any]:
    return {"kind": kind, "version": FORMAT_VERSION, **payload}
