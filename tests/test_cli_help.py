"""Every option of every subcommand explains itself in `--help` (a newcomer's first reading of the tools)."""
from __future__ import annotations

import argparse

import pytest

from baselines.cli import build_parser as baselines_parser
from mahn_envs.cli import build_parser as envs_parser
from mahn_evo.cli import build_parser as evo_parser

TOOLS = {"mahn-evo": evo_parser, "mahn-envs": envs_parser, "mahn-baselines": baselines_parser}


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    assert subs, f"{parser.prog} has no subcommands"
    return dict(subs[0].choices)


def _undocumented(parser: argparse.ArgumentParser) -> list[str]:
    """Options and positionals without help text; hidden ones (help=SUPPRESS) are deliberate."""
    return [a.option_strings[0] if a.option_strings else a.dest for a in parser._actions
            if not isinstance(a, argparse._HelpAction) and not (a.help and a.help.strip())]


CASES = [(tool, name) for tool, build in TOOLS.items() for name in _subcommands(build())]


@pytest.mark.parametrize(("tool", "command"), CASES)
def test_every_option_has_help(tool, command, capsys):
    build = TOOLS[tool]
    sub = _subcommands(build())[command]
    assert _undocumented(sub) == []
    with pytest.raises(SystemExit) as stop:
        build().parse_args([command, "--help"])
    assert stop.value.code == 0
    text = "".join(capsys.readouterr().out.split())  # argparse re-wraps help text, so compare without spaces
    for action in sub._actions:
        if action.help and action.help != argparse.SUPPRESS and "%(" not in action.help:
            assert "".join(action.help.split())[:40] in text, (command, action.dest)


def test_the_check_finds_an_undocumented_option():
    p = argparse.ArgumentParser()
    p.add_argument("--documented", help="says what it does")
    p.add_argument("--bare")
    p.add_argument("--hidden", help=argparse.SUPPRESS)
    assert _undocumented(p) == ["--bare"]


def test_eval_and_generalize_explain_the_options_a_newcomer_asked_about():
    subs = _subcommands(evo_parser())
    helps = {(cmd, a.dest): a.help for cmd in ("eval", "generalize") for a in subs[cmd]._actions}
    assert "asymmetric_plus" in helps[("eval", "map")] and "pymunk" in helps[("eval", "engine")]
    assert "noise" in helps[("eval", "episodes")] and "seed" in helps[("eval", "seed")]
    assert "stages" in helps[("eval", "protocol")]
    for dest in ("run_dir", "episodes", "map", "seed", "noise", "json"):
        assert helps[("generalize", dest)]
