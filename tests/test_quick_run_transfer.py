"""docs/results/quick_run_transfer/: the measuring script runs on a real run folder, and the page's tables are
the ones its data gives (so a re-measured transfer.json cannot leave the page behind)."""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "results" / "quick_run_transfer"


def _transfer_module():
    spec = importlib.util.spec_from_file_location("quick_run_transfer", PAGE / "transfer.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_page_shows_the_tables_of_its_data():
    transfer = _transfer_module()
    tables = transfer.table(PAGE / "transfer.json")
    page = (PAGE / "README.md").read_text()
    assert tables in page
    rows = {r["run"]: r for r in json.loads((PAGE / "transfer.json").read_text())["measures"]}
    # the README's quick run (seed 1): 54.2 in the simulator, 2.3 through the emulator
    assert round(rows["plain_s1"]["training_fitness"], 1) == 54.2
    assert round(rows["plain_s1"]["emulator_mean_fitness"], 1) == 2.3
    assert "| robot | 10 | 3 | 6 | 5 (2, 4, 5, 7, 8) |" in tables


def test_within_is_a_relative_band():
    transfer = _transfer_module()
    assert transfer.within(48.0, 54.2) and transfer.within(60.0, 54.2)
    assert not transfer.within(2.3, 54.2) and not transfer.within(70.0, 54.2)


@pytest.mark.timeout(600)
def test_measure_a_real_run(tmp_path):
    run = tmp_path / "tiny_s3"
    subprocess.run([sys.executable, "-m", "mahn_evo.cli", "train", "--mode", "situational", "--generations", "1",
                    "--pop", "20", "--seed", "3", "--out", str(run)], check=True, capture_output=True)
    transfer = _transfer_module()
    row = transfer.measure(run)
    assert row["seed"] == 3 and row["run"] == "tiny_s3" and len(row["emulator_fitness"]) == 3
    assert row["within_20_training"] == transfer.within(row["emulator_mean_fitness"], row["training_fitness"])
    assert all(f > 0 for f in row["emulator_fitness"])
    assert (run / "emulator_s0.csv").exists()
