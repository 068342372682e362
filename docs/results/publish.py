"""Copy an experiment's report into a docs folder: what the results pages of docs/results/ hold.

An experiment folder (`mahn-evo experiment --out DIR`) keeps every run's checkpoints and archives (hundreds of
MB); a results page keeps what a reader needs: the plan (experiment.json), the report (results.md, results.json,
runs.csv), figures/, replays/, and the most general solutions as champions/<mode>_s<seed>.json (the files the
report's transfer tables were measured on, in today's champion format).  The page's README.md is written by hand
and left alone.

Usage: python docs/results/publish.py EXPERIMENT_DIR DOCS_DIR
"""
from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

REPORT_FILES = ("experiment.json", "results.md", "results.json", "runs.csv")
REPORT_FOLDERS = ("figures", "replays")


def publish(experiment: Path, docs: Path) -> list[Path]:
    """Copy the report of `experiment` into `docs`; returns the files written."""
    results_path = experiment / "results.json"
    if not results_path.exists():
        raise SystemExit(f"{experiment} has no results.json: run `mahn-evo experiment --out {experiment} "
                         "--report-only` first")
    docs.mkdir(parents=True, exist_ok=True)
    written = []
    for name in REPORT_FILES:
        shutil.copy2(experiment / name, docs / name)
        written.append(docs / name)
    for folder in REPORT_FOLDERS:
        if (experiment / folder).is_dir():
            shutil.rmtree(docs / folder, ignore_errors=True)
            shutil.copytree(experiment / folder, docs / folder)
            written += sorted((docs / folder).iterdir())
    results = json.loads(results_path.read_text(encoding="utf-8"))
    champions = docs / "champions"
    shutil.rmtree(champions, ignore_errors=True)
    champions.mkdir()
    for entries in results.get("most_general", {}).values():
        for entry in entries:
            run = Path(entry["file"]).parts[1]  # runs/<mode>_s<seed>/archive/solution_...json
            target = champions / f"{run}.json"
            shutil.copy2(experiment / entry["file"], target)
            written.append(target)
    return written


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    for path in publish(Path(sys.argv[1]), Path(sys.argv[2])):
        print(path)
