"""What a user must know before running robots is written down: the README's safety paragraph states the measured
time from a fault to every reachable robot stopped and the robot-side watchdog a user must set up; the guide
says how."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _readme_safety_paragraph() -> str:
    text = (ROOT / "README.md").read_text()
    start = text.index("- **Safety**")
    return text[start:text.index("\n- **", start + 1)]


def test_readme_states_the_measured_stop_time_and_the_watchdog_to_set_up():
    para = _readme_safety_paragraph()
    assert "benchmarks/bench_stop_latency.py" in para  # the measurement behind the figure
    assert re.search(r"\d+ ms", para) and re.search(r"\d\.\d+ s", para)  # the figures themselves
    assert "watchdog" in para and "must" in para  # what the user has to set up on the robots
    assert "unconfirmed" in para or "confirmed" in para


def test_hardware_guide_documents_the_watchdog_and_the_stop_reports():
    guide = (ROOT / "docs" / "hardware.md").read_text()
    section = guide[guide.index("## 4. Safety"):guide.index("## 5. The emulator")]
    for needed in ["A dead link", "watchdog", "kh3server", "--watchdog", "last_stop_report", "wait_stops",
                   "give_up_stops", "bench_stop_latency.py", "--timeout 0.15"]:
        assert needed in section, needed
    assert "--placement none" in guide or "use `none`" in guide
