"""Numba's on-disk cache, keyed on every source file a compiled function depends on.

Why: numba keys a cached function on its own file only.  The task's rules live in small modules
(``core/task.py``, ``core/geometry.py``, ...) that the kernels inline, so after an edit to ``task.py`` alone a
cached ``run_controllers`` would keep running the old rules, silently, until ``kernels.py`` changed too.  Anyone
who builds on mahn edits exactly those modules, and a git checkout touches only the files that differ.

`register()` puts two locators in front of numba's own: for a function defined in this project's packages
(mahn_envs, mahn_evo, baselines) the cache's freshness stamp is a SHA-256 of its file and of every project module it
imports, transitively (read from the import statements), so a change to any of them recompiles it.  Everything
else about numba's cache (where it lives, ``NUMBA_CACHE_DIR``, file names) is unchanged.  Other libraries' functions
fall through to numba's locators.  The locator list is a numba internal; if a numba release moves it, `register`
warns once and numba's own per-file keying applies.
"""
from __future__ import annotations

import ast
import functools
import hashlib
import warnings
from pathlib import Path

from numba.core import caching

#: the folder holding this project's top-level packages
_ROOT = Path(__file__).resolve().parent.parent
#: the top-level packages whose compiled functions are keyed on their dependencies
PACKAGES = ("mahn_envs", "mahn_evo", "baselines")


def _module_file(parts: list[str]) -> Path | None:
    """The source file of the project module named by `parts` (a package's __init__.py), or None."""
    if not parts or parts[0] not in PACKAGES:
        return None
    base = _ROOT.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _package_parts(path: Path) -> list[str]:
    """The dotted name of the package holding `path`, as parts (mahn_envs/core/task.py -> [mahn_envs, core])."""
    return list(path.resolve().relative_to(_ROOT).parent.parts)


def _add(found: set[Path], module: list[str], names: list[str]) -> None:
    """Add the project files that ``from module import names`` reads: the names that are submodules, and the
    module itself unless it is a package all of whose names are submodules (a package's __init__ re-exports and
    would drag in the whole package)."""
    file = _module_file(module)
    if file is None:
        return
    subs = [sub for sub in (_module_file(module + [n]) for n in names) if sub is not None]
    found.update(subs)
    if file.name != "__init__.py" or len(subs) < len(names) or not names:
        found.add(file)


@functools.cache
def _imports(path: Path) -> tuple[Path, ...]:
    """The project modules `path` imports (absolute and relative imports, submodules named in ``from . import``)."""
    tree = ast.parse(path.read_bytes(), filename=str(path))
    package = _package_parts(path)
    found: set[Path] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):  # `import a.b.c` binds a.b.c's code
            for alias in node.names:
                _add(found, alias.name.split("."), [])
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = base + (node.module.split(".") if node.module else [])
            _add(found, module, [alias.name for alias in node.names])
    found.discard(path)
    return tuple(sorted(found))


def dependencies(path: str | Path) -> tuple[Path, ...]:
    """`path` and every project module it imports, transitively, sorted."""
    start = Path(path).resolve()
    seen = {start}
    todo = [start]
    while todo:
        for dep in _imports(todo.pop()):
            if dep not in seen:
                seen.add(dep)
                todo.append(dep)
    return tuple(sorted(seen))


@functools.cache
def _digest(files: tuple[tuple[str, int, int], ...]) -> bytes:
    """SHA-256 over the relative paths and contents of `files` ((path, mtime_ns, size): the key re-reads a file
    that changed while the process runs)."""
    h = hashlib.sha256()
    for name, _, _ in files:
        h.update(str(Path(name).relative_to(_ROOT)).encode() + b"\0")
        h.update(Path(name).read_bytes() + b"\0")
    return h.digest()


def source_stamp(path: str | Path) -> bytes:
    """The freshness stamp of a compiled function defined in `path`: changes when it or any dependency changes."""
    files = []
    for dep in dependencies(path):
        st = dep.stat()
        files.append((str(dep), st.st_mtime_ns, st.st_size))
    return _digest(tuple(files))


def in_project(py_file: str | Path) -> bool:
    """Whether `py_file` belongs to one of this project's packages (and so gets the dependency stamp)."""
    try:
        parts = Path(py_file).resolve().relative_to(_ROOT).parts
    except ValueError:
        return False
    return len(parts) > 1 and parts[0] in PACKAGES


class _DependencyStamp:
    """Mixin: the stamp of `source_stamp` for project files; locators built only for them."""

    _py_file: str

    def get_source_stamp(self) -> bytes:
        return source_stamp(self._py_file)

    @classmethod
    def from_function(cls, py_func, py_file):  # numba's signature
        if not in_project(py_file):
            return None
        return super().from_function(py_func, py_file)  # type: ignore[misc]


class UserDirDependencyLocator(_DependencyStamp, caching.UserProvidedCacheLocator):
    """numba's NUMBA_CACHE_DIR locator, stamped with the function's dependencies."""


class InTreeDependencyLocator(_DependencyStamp, caching.InTreeCacheLocator):
    """numba's __pycache__ locator, stamped with the function's dependencies."""


class UserWideDependencyLocator(_DependencyStamp, caching.UserWideCacheLocator):
    """numba's per-user cache folder (where __pycache__ is read-only), stamped with the function's dependencies."""


#: in numba's order: NUMBA_CACHE_DIR, then __pycache__, then the user's cache folder
LOCATORS = (UserDirDependencyLocator, InTreeDependencyLocator, UserWideDependencyLocator)


def register() -> bool:
    """Put the dependency-stamped locators first in numba's list (idempotent; call before any cached function of
    the project is defined).  Returns False, with a warning, where this numba has no such list."""
    impl = getattr(caching, "CacheImpl", None)
    classes = getattr(impl, "_locator_classes", None)
    if not isinstance(classes, list):
        warnings.warn("this numba release keeps no cache locator list: compiled kernels are cached per file, so "
                      "after editing a module the kernels inline (e.g. mahn_envs/core/task.py) clear the caches "
                      "(__pycache__/*.nbi, *.nbc)", RuntimeWarning, stacklevel=2)
        return False
    for locator in reversed(LOCATORS):
        if locator not in classes:
            classes.insert(0, locator)
    return True
