"""The sequential (real-world) protocol in simulation: robots see and bump each other, called one at a time."""
import json

import numpy as np
import pytest

from mahn_envs import load_map
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_envs.policies.scripted import WaypointTeam
from mahn_evo.cli import main
from mahn_evo.evaluation.protocols import SequentialSettings, sequential, sequential_episode, sequential_summary

AGENTS = ["robot_0", "robot_1", "robot_2"]


@pytest.mark.parametrize("map_name", ["plus", "asymmetric_plus"])
def test_scripted_team_passes_the_sequential_protocol(map_name):
    res = sequential_episode(WaypointTeam(load_map(map_name), AGENTS), map=map_name, record=True)
    assert res.success and res.stages_completed == 9
    assert sorted(r.post for r in res.robots) == [0, 1, 2]
    assert [r.left_tick is not None for r in res.robots] == [True] * 3
    assert not any(r.stood_when_called for r in res.robots)
    home = load_map(map_name).home
    # each robot was at home at some point after the patrol phase
    for k in range(3):
        assert np.abs(res.trajectory[:, k, :2] - home).sum(axis=1).min() <= 20
    # robots are called one at a time, in the order they left, each after the previous one's call ended; a call
    # ends on the tick the robot is home
    calls = sorted((r.called_tick, r.call_end_tick, k) for k, r in enumerate(res.robots))
    assert [k for _, _, k in calls] == sorted(range(3), key=lambda k: (res.robots[k].left_tick, k))
    for (start, end, k), nxt in zip(calls, calls[1:] + [None]):
        assert start < end and (nxt is None or end < nxt[0])
        assert np.abs(res.trajectory[end - 1, k, :2] - home).sum() <= 20
        assert np.abs(res.trajectory[end - 2, k, :2] - home).sum() > 20


class AlwaysForward:
    def reset(self):
        pass

    def act(self, obs):
        return {a: 1 for a in obs}


def test_a_team_that_never_patrols_fails():
    res = sequential_episode(AlwaysForward(), settings=SequentialSettings(return_ticks=300, out_ticks=300))
    assert not res.success and res.stages_completed < 9
    # a robot that never comes home is waited for return_ticks, and its call's end is recorded
    for r in res.robots:
        if not r.returned_home:
            assert r.called_tick is not None and r.call_end_tick == r.called_tick + 300
    # driving forward, every robot ends pressed against a wall by the reflex: called, it stands still away from home
    assert [r.stood_when_called for r in res.robots] == [not r.returned_home for r in res.robots] == [True] * 3
    out = sequential(AlwaysForward(), episodes=2, settings=SequentialSettings(return_ticks=200, out_ticks=200))
    assert out["solved"] == [False, False] and len(out["fitness"]) == 2
    # the text `mahn-evo eval --protocol sequential` prints counts stages out of 9 and says what a stage is
    text = sequential_summary(out, "plus")
    for e, ep in enumerate(out["episodes"]):
        assert f"episode {e}: fail, {ep['stages_completed']}/9 stages" in text
    assert "3 per robot" in text and "came home when called" in text and "went back out" in text
    assert "called and standing still away from home: robot_0, robot_1, robot_2" in text


def test_situational_controller_restarts_patrol_brain_when_signal_cleared():
    from tests.envs.helpers import random_team

    pol = ControllerPolicy(random_team(0, n_brains=2), AGENTS)
    obs = {a: np.ones(7, np.float32) for a in AGENTS}
    pol.act(obs)
    assert pol._brain[0].tolist() == [1, 1, 1]
    obs = {a: np.ones(7, np.float32) * np.array([1, 1, 1, 1, 1, 1, 0], np.float32) for a in AGENTS}
    pol.act(obs)
    assert pol._brain[0].tolist() == [0, 0, 0]


def test_cli_sequential(tmp_path, capsys):
    from mahn_evo.training.config import EvolutionConfig
    from mahn_evo.training.trainer import train

    train(EvolutionConfig(generations=1, seed=0).with_overrides(pop=10), tmp_path)
    assert main(["eval", str(tmp_path / "champion.json"), "--protocol", "sequential", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["protocol"] == "sequential" and len(out["solved"]) == 1


def test_sequential_frames_and_cli_video_and_plot(tmp_path):
    frames = []
    short = SequentialSettings(patrol_ticks=200, return_ticks=60, out_ticks=60)
    res = sequential_episode(AlwaysForward(), settings=short, record=True, frames=frames, frame_every=20)
    assert len(frames) == len(res.trajectory) // 20 and frames[0].ndim == 3 and frames[0].shape[2] == 3
    assert not np.array_equal(frames[0], frames[-1])  # the robots moved

    from mahn_evo.training.config import EvolutionConfig
    from mahn_evo.training.trainer import train

    train(EvolutionConfig(generations=1, seed=0).with_overrides(pop=10), tmp_path)
    gif, png = tmp_path / "seq.gif", tmp_path / "seq.png"
    assert main(["eval", str(tmp_path / "champion.json"), "--protocol", "sequential", "--video", str(gif),
                 "--plot", str(png)]) == 0
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames > 10
    assert png.stat().st_size > 5000
