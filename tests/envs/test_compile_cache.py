"""Numba's on-disk cache must recompile a kernel when a module it inlines changes (mahn_envs.compile_cache).

The end-to-end test builds a two-module package in a temporary folder: a rule module with an inlined constant and a
kernel module that calls it.  Run in fresh processes with one NUMBA_CACHE_DIR, the kernel is compiled, then loaded
from the cache, then the rule is edited: with the dependency stamp the next process sees the new rule; with numba's
own per-file stamp (the control) it runs the stale compiled rule, which is the hazard this module removes.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mahn_envs import compile_cache
from mahn_envs.core import kernels

RULE = """\
from numba import njit

BONUS = {bonus}


@njit(cache=True, inline="always")
def bonus():
    return BONUS
"""

KERNEL = """\
from numba import njit

from .rule import bonus


@njit(cache=True)
def total():
    return bonus() + 1.0
"""

# runs in a fresh interpreter: the demo package counts as a project package when the stamp is on
SCRIPT = """\
import json, sys
from pathlib import Path
import numba.core.caching as caching
root, stamped = Path(sys.argv[1]), sys.argv[2] == "1"
if stamped:
    from mahn_envs import compile_cache
    compile_cache._ROOT = root
    compile_cache.PACKAGES = ("demo",)
    compile_cache.register()
else:  # numba's own locators only (mahn_envs may have registered its own: take them out)
    import mahn_envs.compile_cache as cc
    for loc in cc.LOCATORS:
        if loc in caching.CacheImpl._locator_classes:
            caching.CacheImpl._locator_classes.remove(loc)
sys.path.insert(0, str(root))
from demo.kernel import total
value = total()
print(json.dumps({"value": value, "hits": sum(total.stats.cache_hits.values()),
                  "locator": type(total._cache._impl.locator).__name__}))
"""


def _make_package(root: Path, bonus: float) -> None:
    pkg = root / "demo"
    pkg.mkdir(parents=True, exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "kernel.py").write_text(KERNEL)
    _write_rule(root, bonus)


def _write_rule(root: Path, bonus: float) -> None:
    rule = root / "demo" / "rule.py"
    rule.write_text(RULE.format(bonus=bonus))
    # a later mtime even on coarse clocks (numba and the stamp both re-read a file whose stat changed)
    st = rule.stat()
    os.utime(rule, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))


def _run(root: Path, cache: Path, stamped: bool) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    out = subprocess.run([sys.executable, "-c", SCRIPT, str(root), "1" if stamped else "0"], env=env,
                         capture_output=True, text=True, timeout=300, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("stamped", [True, False], ids=["dependency_stamp", "numba_per_file_control"])
def test_editing_an_inlined_rule_recompiles_the_kernel(tmp_path: Path, stamped: bool) -> None:
    root, cache = tmp_path / "src", tmp_path / "cache"
    _make_package(root, 100.0)
    first = _run(root, cache, stamped)
    assert first["value"] == 101.0 and first["hits"] == 0  # compiled and saved
    again = _run(root, cache, stamped)
    assert again["value"] == 101.0 and again["hits"] == 1  # loaded from the cache: the cache is in use
    assert again["locator"] == ("UserDirDependencyLocator" if stamped else "UserProvidedCacheLocator")
    _write_rule(root, 200.0)
    edited = _run(root, cache, stamped)
    if stamped:
        assert edited["value"] == 201.0 and edited["hits"] == 0  # the edit reached the compiled kernel
    else:
        assert edited["value"] == 101.0 and edited["hits"] == 1  # numba alone: the stale rule


def test_the_kernels_are_stamped_with_the_task_rules() -> None:
    """The compiled episode kernel's stamp covers the modules it inlines (task rules, geometry, RNG, Khepera
    constants), and only those of the project."""
    names = {p.relative_to(compile_cache._ROOT).as_posix()
             for p in compile_cache.dependencies(kernels.__file__)}
    assert {"mahn_envs/core/kernels.py", "mahn_envs/core/task.py", "mahn_envs/core/geometry.py",
            "mahn_envs/core/rng.py", "mahn_envs/core/controller.py", "mahn_envs/khepera.py"} <= names
    assert "mahn_envs/__init__.py" not in names and not any(n.startswith("mahn_evo/") for n in names)
    assert type(kernels.run_controllers._cache._impl.locator) in compile_cache.LOCATORS


def test_register_is_idempotent_and_leaves_other_libraries_to_numba(tmp_path: Path) -> None:
    import numba.core.caching as caching

    assert compile_cache.register() and compile_cache.register()
    classes = caching.CacheImpl._locator_classes
    assert all(classes.count(loc) == 1 for loc in compile_cache.LOCATORS)
    outside = tmp_path / "other.py"
    outside.write_text("def f():\n    return 1\n")
    assert not compile_cache.in_project(outside)
    assert compile_cache.in_project(kernels.__file__)


def test_the_stamp_changes_with_a_dependency(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = tmp_path / "src"
    _make_package(root, 1.0)
    monkeypatch.setattr(compile_cache, "_ROOT", root)
    monkeypatch.setattr(compile_cache, "PACKAGES", ("demo",))
    kernel = root / "demo" / "kernel.py"
    assert compile_cache.dependencies(kernel) == (kernel, root / "demo" / "rule.py")
    before = compile_cache.source_stamp(kernel)
    assert compile_cache.source_stamp(kernel) == before
    _write_rule(root, 2.0)
    assert compile_cache.source_stamp(kernel) != before
