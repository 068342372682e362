"""The published standard-geometry comparison (docs/results/baselines/fair_neat_direct_standard/) quotes exactly
what its script computes from the kept runs, so a changed run file or statistic shows up here."""
from __future__ import annotations

import contextlib
import io
import runpy
from pathlib import Path

PAGE = Path(__file__).resolve().parents[2] / "docs" / "results" / "baselines" / "fair_neat_direct_standard"


def test_standard_comparison_page_quotes_its_script():
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        runpy.run_path(str(PAGE / "table.py"), run_name="__main__")
    rows = out.getvalue().strip().splitlines()
    assert len(rows) == 5 and rows[2].startswith("| NEAT-direct, standard | 15 | 4/15")
    page = (PAGE / "README.md").read_text()
    missing = [r for r in rows if r not in page]
    assert not missing, f"README.md does not quote these rows of table.py: {missing}"
