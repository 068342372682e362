"""The README's two set-up commands stay true: CI runs the README's test command verbatim."""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _commands(text: str) -> list[str]:
    blocks = text.split("```bash\n")[1:]
    return [b.split("```")[0].strip() for b in blocks]


def test_ci_runs_the_readme_test_command():
    readme = (ROOT / "README.md").read_text()
    test_cmd = [c for c in _commands(readme) if "pytest" in c]
    assert len(test_cmd) == 1
    assert test_cmd[0] in (ROOT / ".ci" / "run").read_text()


def test_main_job_is_a_situational_training_run_with_a_picture():
    readme = (ROOT / "README.md").read_text()
    main = _commands(readme)[0]
    assert main.startswith("pip install -e .") and "mahn-evo train --mode situational" in main and "--gif" in main
