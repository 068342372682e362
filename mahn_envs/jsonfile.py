"""Reading the JSON files users hand us (maps, champions, run files): one rule for the errors that name them.

It lives in mahn_envs because the env reads map files and must not import the trainer; mahn_evo.storage.files
re-exports it for the trainer's files.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def read_text_file(path: str | Path, what: str) -> str:
    """A file's UTF-8 text; a missing file, a folder or undecodable bytes is a ValueError naming it."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"{what} file {str(path)!r} does not exist")
    if path.is_dir():
        raise ValueError(f"{what} file {str(path)!r} is a folder, not a file")
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{what} file {str(path)!r} is not UTF-8 text ({exc})") from exc


def read_json_object(path: str | Path, what: str) -> dict[str, Any]:
    """A JSON object from a file; a missing file, a folder, undecodable or corrupt JSON or another top level is a
    ValueError naming it."""
    text = read_text_file(path, what)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what} file {str(Path(path))!r} is corrupt (not valid JSON: {exc})") from exc
    except RecursionError as exc:
        raise ValueError(f"{what} file {str(Path(path))!r} is nested too deeply to be a {what} file") from exc
    if not isinstance(data, dict):
        raise ValueError(f"{what} file {str(Path(path))!r} must hold a JSON object")
    return data
