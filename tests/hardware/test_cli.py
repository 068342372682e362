"""`mahn-envs emulate` as a separate process, driven by `mahn-evo deploy` over real TCP on loopback."""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from mahn_envs.cli import main as envs_main
from mahn_evo.deploy import add_deploy_parser
from mahn_evo.deploy import main as deploy_main

from ..envs.helpers import random_team

pytestmark = pytest.mark.timeout(120)
ROOT = Path(__file__).resolve().parents[2]


def _champion(tmp_path: Path) -> Path:
    path = tmp_path / "champion.json"
    path.write_text(json.dumps({"controllers": random_team(2).to_dict()}))
    return path


def test_emulate_command_serves_deploy(tmp_path, capsys):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "mahn_envs.cli", "emulate", "--robots", "3", "--port", "0",
                             "--time-scale", "2", "--duration", "90"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    try:
        ports = None
        lines = []
        timer = threading.Timer(60, proc.kill)  # never hang on a broken emulator
        timer.start()
        for line in proc.stdout:
            lines.append(line)
            if line.startswith("ports: "):
                ports = line.split(": ", 1)[1].strip().split(",")
                break
        timer.cancel()
        assert ports and all(p.startswith("socket://127.0.0.1:") for p in ports), lines
        log = tmp_path / "log.csv"
        code = deploy_main(["deploy", str(_champion(tmp_path)), "--ports", *ports, "--placement", "none",
                            "--max-cycles", "45", "--time-scale", "2", "--log", str(log),
                            "--timeout", "1.0"])  # a subprocess emulator on a busy machine answers slowly
        out = capsys.readouterr().out
        assert code == 0 and "situational team, 45 ticks" in out and "fitness n/a" in out
        assert len(log.read_text().splitlines()) == 1 + 45 * 3
    finally:
        proc.send_signal(signal.SIGINT)
        try:  # a clean stop, however slow: on a loaded machine with cold numba caches it took over 20 s
            rest, err = proc.communicate(timeout=90)
        except subprocess.TimeoutExpired:
            proc.kill()
            rest, err = proc.communicate()
    assert proc.returncode == 0, err
    assert "emulator stopped" in rest and "emulator errors" not in err


def test_deploy_against_the_in_process_emulator(tmp_path, capsys):
    log = tmp_path / "emu.csv"
    code = deploy_main(["deploy", str(_champion(tmp_path)), "--emulate", "--max-cycles", "30",
                        "--time-scale", "3", "--log", str(log)])
    out = capsys.readouterr().out
    assert code == 0 and "30 ticks" in out and "team fitness" in out and log.exists()


def test_deploy_parser_registers_on_any_subparsers(tmp_path, capsys):
    parser = argparse.ArgumentParser(prog="mahn-evo")
    sub = parser.add_subparsers(dest="command")
    add_deploy_parser(sub)
    args = parser.parse_args(["deploy", "c.json", "--ports", "/dev/rfcomm0", "/dev/rfcomm1", "/dev/rfcomm2"])
    assert args.func is not None and args.ports == ["/dev/rfcomm0", "/dev/rfcomm1", "/dev/rfcomm2"]
    code = args.func(parser.parse_args(["deploy", str(tmp_path / "missing.json"), "--emulate"]))
    assert code == 1 and "does not exist" in capsys.readouterr().err


def test_emulate_rejects_bad_faults(capsys):
    assert envs_main(["emulate", "--port", "0", "--fault", "1:explode"]) == 2
    assert "unknown fault" in capsys.readouterr().err


def test_emulate_in_process_with_duration(capsys):
    assert envs_main(["emulate", "--port", "0", "--robots", "2", "--duration", "0.3", "--status", "0.1",
                      "--fault", "0:drop:2:N"]) == 0
    out = capsys.readouterr().out
    assert "robot_1: socket://127.0.0.1:" in out and "robot_0: (" in out and "emulator stopped" in out


def test_deploy_without_a_terminal_names_placement_none_and_leaves_no_empty_log(tmp_path, capsys, monkeypatch,
                                                                                 make_emulator):
    import io

    emu = make_emulator()
    monkeypatch.setattr("sys.stdin", io.StringIO(""))  # no terminal: input() meets the end of stdin
    log = tmp_path / "robots.csv"
    code = deploy_main(["deploy", str(_champion(tmp_path)), "--ports", *emu.ports, "--log", str(log)])
    err = capsys.readouterr().err
    assert code == 1 and "--placement none" in err and "Traceback" not in err
    assert not log.exists()  # no empty CSV left behind
    assert all(emu.world.stopped(k) for k in range(3)) and all(c[-1] == "D,l0,l0" for c in map(emu.commands, range(3)))
    # with the emulator the default is no prompt (it places its robots); asking for one still asks
    log2 = tmp_path / "emu.csv"
    assert deploy_main(["deploy", str(_champion(tmp_path)), "--emulate", "--max-cycles", "5", "--time-scale", "3",
                        "--log", str(log2)]) == 0 and log2.exists()
    log3 = tmp_path / "emu-prompt.csv"
    assert deploy_main(["deploy", str(_champion(tmp_path)), "--emulate", "--placement", "prompt",
                        "--max-cycles", "5", "--log", str(log3)]) == 1
    assert "--placement none" in capsys.readouterr().err and not log3.exists()
