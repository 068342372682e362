"""The whole hardware path on loopback: env -> pyserial -> TCP -> emulator -> simulator geometry and back.

A scripted waypoint team (mahn_envs.policies.scripted.WaypointTeam, steering from the poses the emulator's "overhead
tracker" reports) completes patrol-and-return through the emulator, scored by the simulator's own fitness
code.  This proves the hardware path is right end to end - wheel commands in firmware units move robots at
the simulator's speeds and turn rates, the pacing gives 33 ms ticks, the signal schedule reaches the agents,
the IR readings survive noise, inverse calibration and calibration well enough for the reflex not to
interfere - not that any particular evolved team transfers (that is the paper's experiment).
"""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from mahn_envs.hardware import Episode, KheperaHardwareEnv, Link, Poses, RealClock, RetryPolicy, Timing, VirtualClock
from mahn_envs.hardware import protocol as P
from mahn_envs.policies.scripted import WaypointTeam
from mahn_evo.deploy import LOG_HEADER, deploy

from ..envs.helpers import random_team
from .conftest import last_command

pytestmark = pytest.mark.timeout(120)


def test_scripted_team_completes_patrol_and_return_through_the_emulator(make_env):
    env, emu = make_env(emu_kwargs={"noise": 1.0, "seed": 5})  # a real robot's IR noise, lock-step clock
    obs, infos = env.reset()
    team = WaypointTeam(env.world, env.possible_agents)
    rewards = 0.0
    while env.agents:
        obs, rew, terms, truncs, infos = env.step(team.act(infos))
        rewards += rew["robot_0"]
    info = infos["robot_0"]
    assert info["tick"] == 1364 and info["solved"] is True and info["team_fitness"] > 100
    assert rewards == pytest.approx(info["team_fitness"])
    assert all(last_command(emu, k) == "D,l0,l0" for k in range(3))  # stopped at the end of the episode
    # the robots really went to the three POIs and came home: check the tracker's final poses
    final = emu.poses()[:, :2]
    assert np.all(np.abs(final - env.world.home).sum(axis=1) <= 20.0)


def test_real_time_pacing_gives_33_ms_ticks(make_emulator):
    """Real clock, real sockets: the measured period is reported per tick and is the control period."""
    clock = RealClock(1.0)
    emu = make_emulator(clock=clock)
    with KheperaHardwareEnv(emu.ports, timing=Timing(clock=clock),
                            poses=Poses(placement=emu.place, pose_source=emu.poses), catch_sigterm=False,
                            link=Link(retry=RetryPolicy(timeout=1.0))) as env:
        env.reset()
        periods = []
        for _ in range(75):
            _, _, _, _, infos = env.step({a: 1 for a in env.agents})
            periods.append(infos["robot_0"]["period"])
        # 75 ticks at 9 cm/s: ~22 cm in ~2.5 s, whatever the jitter
        moved = emu.poses()[0, 1] - env.world.starts[0, 1]
    p = np.asarray(periods[1:])
    assert 0.030 < np.median(p) < 0.040, np.median(p)
    assert moved == pytest.approx(9.0 * p.sum() + 9.0 * periods[0], rel=0.15)


@pytest.mark.parametrize("n_brains", [1, 2])
def test_deploy_runs_standard_and_situational_teams_and_logs_every_tick(tmp_path, n_brains):
    team = random_team(11, n_brains=n_brains)
    champ = tmp_path / "champion.json"
    champ.write_text(json.dumps({"kind": "champion", "map": "plus", "controllers": team.to_dict()}))
    log = tmp_path / "run.csv"
    ticks = []
    result = deploy(champ, emulate=True, clock=VirtualClock(), log_path=log,
                    env_kwargs={"episode": Episode(max_cycles=60, signal_tick=30)},
                    on_tick=lambda t, infos: ticks.append(t))
    assert result.ticks == 60 and ticks == list(range(1, 61))
    assert result.mode == ("situational" if n_brains == 2 else "standard")
    assert result.mean_period == pytest.approx(0.033) and result.team_fitness is not None
    rows = list(csv.DictReader(log.open()))
    assert tuple(rows[0].keys()) == LOG_HEADER and len(rows) == 60 * 3
    for row in rows:
        cmd = P.parse_command(row["command"])  # a valid D command as sent on the wire
        assert cmd.letter == "D" and row["motion"] in ("forward", "left", "right", "stop", "arc_left", "arc_right")
        assert row["action"] in ("0", "1", "2") and float(row["period"]) == pytest.approx(0.033)
        outs = [float(row[k]) for k in ("out_left", "out_forward", "out_right")]
        assert all(0.0 <= o <= 1.0 for o in outs)
        assert int(row["action"]) == (1 if outs[1] >= max(outs) else 0 if outs[0] >= outs[2] else 2)
        assert row["x"] != ""
    # the signal input reaches the network from tick 31 on (given after tick 30's motion)
    assert {r["signal"] for r in rows if int(r["tick"]) <= 30} == {"0"}
    assert {r["signal"] for r in rows if int(r["tick"]) > 30} == {"1"}


def test_deploy_input_errors(tmp_path):
    champ = tmp_path / "c.json"
    champ.write_text(json.dumps({"controllers": random_team(1).to_dict()}))
    with pytest.raises(ValueError, match="3 robots but 2 port"):
        deploy(champ, ["socket://127.0.0.1:1", "socket://127.0.0.1:2"])
    with pytest.raises(ValueError, match="one port per robot"):
        deploy(champ)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        deploy(bad, emulate=True)
    bad.write_text(json.dumps({"fitness": 3}))
    with pytest.raises(ValueError, match="no 'controllers'"):
        deploy(bad, emulate=True)
