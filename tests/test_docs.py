"""The docs stay true to the repository: citations point inside it, and docs/architecture.md names every module
that exists and nothing that does not (so a move or a new module shows up here until the page is updated)."""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("mahn_envs", "mahn_evo", "baselines")
TEXT_SUFFIXES = {".py", ".md", ".toml"}


def _repo_text_files() -> list[Path]:
    skip = {".git", "runs", "build", "dist", ".pytest_cache", ".hypothesis", "__pycache__"}
    out = []
    for p in ROOT.rglob("*"):
        if p.is_file() and p.suffix in TEXT_SUFFIXES and not (set(p.relative_to(ROOT).parts) & skip):
            out.append(p)
    return out


def _citations_outside_the_repo(text: str) -> list[str]:
    return re.findall(r"shared/reference\S*|\breference/[\w-]+\.md|\bDESIGN\.md", text)


def test_no_citation_points_outside_the_repository():
    bad = {}
    for p in _repo_text_files():
        if p.resolve() == Path(__file__).resolve():
            continue
        found = _citations_outside_the_repo(p.read_text(errors="replace"))
        if found:
            bad[str(p.relative_to(ROOT))] = found
    assert bad == {}, "cite docs/original-system.md or docs/architecture.md instead"


def test_the_citation_check_finds_old_citations():
    assert _citations_outside_the_repo("see shared/reference/khepera3.md and DESIGN.md") == [
        "shared/reference/khepera3.md", "DESIGN.md"]
    assert _citations_outside_the_repo("(reference/iros2011-original-system.md)") == [
        "reference/iros2011-original-system.md"]
    assert _citations_outside_the_repo("docs/original-system.md section 6") == []


def _modules() -> set[str]:
    """Every module of the packages as a repo-relative path; a package's own __init__.py is only a marker."""
    return {p.relative_to(ROOT).as_posix() for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")
            if p.name != "__main__.py" and p.relative_to(ROOT).as_posix() != f"{pkg}/__init__.py"}


def _architecture_tables() -> dict[str, str]:
    """Module-map rows of docs/architecture.md: the first cell's backticked names, resolved against the table's
    package heading (### `mahn_envs` ...)."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    section = text.split("## Module map", 1)[1].split("\n## ", 1)[0]
    rows: dict[str, str] = {}
    pkg = None
    for line in section.splitlines():
        m = re.match(r"### `([\w/]+)`", line)
        if m:
            pkg = m.group(1)
            continue
        if pkg and line.startswith("| `"):
            first = line.split("|")[1]
            for name in re.findall(r"`([^`]+)`", first):
                rows[f"{pkg}/{name}"] = line
    return rows


def _covered(module: str, named: set[str]) -> bool:
    """Named itself, or inside a folder row (`engines/`), or a subpackage's __init__.py whose folder has rows."""
    folder = module.rsplit("/", 1)[0] + "/"
    if module in named or any(module.startswith(n) for n in named if n.endswith("/")):
        return True
    return module.endswith("/__init__.py") and any(n.startswith(folder) for n in named)


def test_architecture_module_map_matches_the_code():
    named = set(_architecture_tables())
    missing = {m for m in _modules() if not _covered(m, named)}
    assert missing == set(), "modules docs/architecture.md does not mention in its module map"
    stale = {n for n in named if not (ROOT / n).exists()}
    assert stale == set(), "docs/architecture.md names modules that do not exist"


def test_architecture_folder_rows_name_every_module_inside():
    for name, row in _architecture_tables().items():
        if not name.endswith("/") or name == "mahn_envs/hardware/":
            continue  # hardware has a table of its own
        for p in (ROOT / name).glob("*.py"):
            if p.name != "__init__.py":
                assert f"`{p.name}`" in row, f"{name} row does not mention {p.name}"


def _robot_rows_module():
    """docs/results/experiment_robot/rows.py, loaded as a module (it is a script, not a package module)."""
    spec = importlib.util.spec_from_file_location("experiment_robot_rows",
                                                  ROOT / "docs" / "results" / "experiment_robot" / "rows.py")
    rows_py = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rows_py)
    return rows_py


def test_the_robot_experiment_table_is_made_from_its_rows():
    """docs/results/experiment_robot/README.md quotes rows.py's table of runs.jsonl, word for word."""
    import json

    folder = ROOT / "docs" / "results" / "experiment_robot"
    rows_py = _robot_rows_module()
    rows = [json.loads(line) for line in (folder / "runs.jsonl").read_text().splitlines() if line.strip()]
    assert rows, "runs.jsonl is empty"
    assert rows_py.table(rows) in (folder / "README.md").read_text()


def test_the_robot_experiment_keeps_published_rows_when_collected_again():
    """rows.py's merge (collect ... PUBLISHED): rows of runs a folder no longer holds stay, a run collected again
    replaces its row and keeps its published check when it was collected without one."""

    rows_py = _robot_rows_module()
    published = [{"seed": 1, "run": "situational_s001", "generations": 534, "check": {"pick": "a"}, "probes": {}},
                 {"seed": 2, "run": "situational_s002", "generations": 437, "check": {"pick": "b"}}]
    collected = [{"seed": 2, "run": "situational_s002", "generations": 437},
                 {"seed": 6, "run": "situational_s006", "generations": 702, "check": {"pick": "c"}}]
    assert rows_py.merged(published, collected) == [
        published[0], {"seed": 2, "run": "situational_s002", "generations": 437, "check": {"pick": "b"}},
        collected[1]]


def test_the_robot_experiment_ranking_is_made_from_its_rows_and_picks():
    """docs/results/experiment_robot/README.md quotes rows.py's ranking of the published picks, word for word."""
    import json

    folder = ROOT / "docs" / "results" / "experiment_robot"
    rows_py = _robot_rows_module()
    rows = [json.loads(line) for line in (folder / "runs.jsonl").read_text().splitlines() if line.strip()]
    table = rows_py.ranking_table(rows_py.ranking(rows, folder / "champions"), len(rows))
    assert table in (folder / "README.md").read_text()


def test_the_side_by_side_table_is_made_from_the_pages():
    """docs/results/README.md quotes side_by_side.py's table (the paper beside the faithful and robust 15 + 15
    experiments, read from the pages' results.json), word for word."""
    spec = importlib.util.spec_from_file_location("side_by_side", ROOT / "docs" / "results" / "side_by_side.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    table = module.table()
    assert "| robust (" in table and "15/15 | 436.3 (305.1) | 3/15 | 1.1e-05" in table
    assert table in (ROOT / "docs" / "results" / "README.md").read_text()


def test_the_confirmation_table_is_made_from_its_record():
    """experiment_hardened_sequential/README.md quotes confirmation.py's table and verdict of confirmation.json,
    word for word, and the verdict is the one the page states (4 of 5 by the rule fixed in advance)."""
    import json

    folder = ROOT / "docs" / "results" / "experiment_hardened_sequential"
    spec = importlib.util.spec_from_file_location("confirmation", folder / "confirmation.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    data = json.loads((folder / "confirmation" / "confirmation.json").read_text())
    verdict = module.verdict(data)
    assert verdict["confirmed"] and verdict["protocol"]["robust"] == 4 and verdict["generalization"]["robust"] == 3
    assert module.table(data) in (folder / "README.md").read_text()


@pytest.mark.parametrize("method,best_row,ending", [
    ("ppo_ff", "| 30 | completed | **15.45** |", "25 finished trials; 6 cut off by an interruption and run again"),
    ("ippo_gru", "| 20 | completed | **3.09** |", "25 finished trials; 3 cut off by an interruption and run again"),
    ("mappo_gru", "| 28 | completed | **42.53** |", "25 finished trials; 4 cut off by an interruption and run again"),
])
def test_the_finished_tuning_tables_are_made_from_their_journals(method, best_row, ending):
    """docs/results/baselines/fair_runs/README.md quotes each finished study trial by trial as `mahn-baselines tune
    --table` prints it from the kept journal, word for word."""
    pytest.importorskip("optuna")
    from baselines.lean.tune import trials_table

    folder = ROOT / "docs" / "results" / "baselines" / "fair_runs"
    table = trials_table(folder / f"tune_{method}", method)
    assert best_row in table and table.endswith(ending)
    assert table in (folder / "README.md").read_text()


def test_the_partial_fair_comparison_quotes_its_own_table():
    """docs/results/baselines/fair/README.md quotes the full-budget table of its comparison.md (what `compare`
    wrote), word for word, so remaking the page with the RL runs cannot leave an old table behind."""
    folder = ROOT / "docs" / "results" / "baselines" / "fair"
    table = (folder / "comparison.md").read_text().split("## At full budget\n\n")[1].split("\n\n")[0]
    assert "| ipop_cmaes_direct_situational | 15 |" in table
    assert table in (folder / "README.md").read_text()
