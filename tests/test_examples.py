"""The examples that write files write them into an output folder (runs/examples/) or a temporary folder, never
into the repository: run as a user would, from a folder of their own, and the repository stays as it was."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SKIP_DIRS = {".git", "__pycache__", ".pytest_cache", ".hypothesis", "runs", "build", "dist"}


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    """Size and modification time of every file a run could touch (caches and run folders excluded)."""
    out = {}
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if d not in SKIP_DIRS and not d.endswith(".egg-info")]
        for name in files:
            st = os.stat(os.path.join(folder, name))
            out[os.path.relpath(os.path.join(folder, name), root)] = (st.st_size, st.st_mtime_ns)
    return out


def _run_example(name: str, cwd: Path, *args: str) -> str:
    env = dict(os.environ, PYTHONPATH=str(REPO), MPLBACKEND="Agg", SDL_VIDEODRIVER="dummy")
    done = subprocess.run([sys.executable, str(REPO / "examples" / name), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize(("example", "output"), [
    ("plot_maps.py", "runs/examples/maps.png"),
    ("scripted_team_gif.py", "runs/examples/scripted_team.gif"),
    ("custom_map.py", None),  # its map file lives in a temporary folder
])
def test_examples_write_only_into_an_output_folder(example, output, tmp_path):
    before = _snapshot(REPO)
    stdout = _run_example(example, tmp_path)
    assert _snapshot(REPO) == before, "the example changed or added files in the repository"
    written = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file())
    assert written == ([output] if output else []), stdout
    if example == "custom_map.py":
        assert "solved True" in stdout and "rejected as expected" in stdout


def test_the_snapshot_sees_a_new_file(tmp_path):
    (tmp_path / "a.txt").write_text("a")
    before = _snapshot(tmp_path)
    (tmp_path / "b.txt").write_text("b")
    assert _snapshot(tmp_path) != before
