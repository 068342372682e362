"""Storage: the files users keep, and the rules that keep them safe and readable for years.

This folder holds atomic, versioned JSON/CSV writing and reading with clear errors, and checksummed files for
checkpoints (`files`), the one migration path from older file formats (`migrate`: `FORMAT_VERSION`, `upgrade`,
one step per version) and the lock that keeps one process per run or experiment folder (`folder_lock`).  It
exports `FORMAT_VERSION`, `atomic_write_json`, `read_versioned_json`, `versioned` and `folder_lock`.
"""
from .files import atomic_write_json, read_versioned_json, versioned
from .folder_lock import folder_lock
from .migrate import FORMAT_VERSION

__all__ = ["FORMAT_VERSION", "atomic_write_json", "read_versioned_json", "versioned", "folder_lock"]
