"""One process per run or experiment folder: a lock file naming the pid that holds it.

Two processes writing into one folder (a rerun beside the orphaned workers of a killed experiment, two
`mahn-evo train` in one --out) interleave generations and corrupt the run silently.  The lock is an flock on
`<folder>/.mahn.lock`: the kernel releases it when its process dies, however it dies, so a lock left by a
dead pid is simply taken over; the pid written in the file only serves the message.
"""
from __future__ import annotations

import errno
import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

LOCK_NAME = ".mahn.lock"


def _read_pid(path: Path) -> int | None:
    try:
        text = path.read_text(encoding="ascii").strip()
    except (OSError, UnicodeDecodeError):
        return None
    return int(text) if text.isdigit() else None


def _try_lock(path: Path) -> int | None:
    """An fd holding the lock on `path`, or None if another process holds it."""
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                return None
            raise
        try:  # the holder before us may have unlinked the file between our open and our flock: lock the new one
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)


def lock_holder(folder: str | Path) -> int | None:
    """The pid of the live process holding `folder`'s lock (0 if it cannot be read), or None if it is free."""
    path = Path(folder) / LOCK_NAME
    if not path.exists():
        return None
    fd = _try_lock(path)
    if fd is None:
        return _read_pid(path) or 0
    os.close(fd)
    return None


def check_folder_usable(folder: str | Path, what: str) -> Path:
    """`folder` is a folder or can be made one: an existing file in its place is a ValueError naming it."""
    folder = Path(folder)
    for p in (folder, *folder.parents):
        if p.exists():
            if not p.is_dir():
                raise ValueError(f"{what} {str(folder)!r}: {str(p)!r} is a file, not a folder")
            if not os.access(p, os.W_OK | os.X_OK):
                raise ValueError(f"{what} {str(folder)!r}: {str(p)!r} is not writable")
            break
    return folder


@contextmanager
def folder_lock(folder: str | Path, what: str = "folder") -> Iterator[Path]:
    """Hold `folder` (created if needed) for this process; a folder held by a live process is a ValueError naming
    its pid.  A folder this call created and left empty is removed again, so a refused start leaves nothing."""
    folder = check_folder_usable(folder, what)
    created = not folder.exists()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{what} {str(folder)!r} cannot be created: {exc.strerror or exc}") from exc
    path = folder / LOCK_NAME
    fd = _try_lock(path)
    if fd is None:
        pid = _read_pid(path)
        raise ValueError(f"{what} {str(folder)!r} is in use by process {pid if pid else '(unknown)'} (lock file "
                         f"{str(path)!r}); stop that process first, or wait for it to finish")
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        yield folder
    finally:
        try:
            path.unlink(missing_ok=True)
        finally:
            os.close(fd)
        if created:
            try:
                folder.rmdir()  # only succeeds when empty
            except OSError:
                pass
