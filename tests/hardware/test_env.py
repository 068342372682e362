"""KheperaHardwareEnv against the emulator on loopback (lock-step clock): interface, semantics, safety."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mahn_envs import patrol_return_v0
from mahn_envs.hardware import Driving, Episode, KheperaHardwareEnv, Link, Poses, RetryPolicy, Sensing, Timing
from mahn_envs.hardware.errors import LinkError
from mahn_envs.hardware.kinematics import SPEED_UNIT_V2

from .conftest import last_command

pytestmark = pytest.mark.timeout(60)


def test_same_agents_spaces_and_info_keys_as_the_simulated_env(make_env):
    env, emu = make_env()
    sim = patrol_return_v0.parallel_env()
    assert env.possible_agents == sim.possible_agents
    for a in env.possible_agents:
        assert env.observation_space(a) == sim.observation_space(a)
        assert env.action_space(a) == sim.action_space(a)
    assert env.policy_coordinates == sim.policy_coordinates
    obs, infos = env.reset(seed=3)
    sim_obs, sim_infos = sim.reset(seed=3)
    assert set(obs) == set(sim_obs)
    for a in env.agents:
        assert env.observation_space(a).contains(obs[a])
        assert set(sim_infos[a]) <= set(infos[a])
        # same start poses, and the same readings up to the calibration round trip (noise off)
        np.testing.assert_allclose(infos[a]["pose"], sim_infos[a]["pose"])
        np.testing.assert_allclose(obs[a], sim_obs[a], atol=0.01)
    out = env.step({a: 1 for a in env.agents})
    assert len(out) == 5
    obs, rewards, terms, truncs, infos = out
    for a in env.agents:
        assert {"pose", "signal", "period", "command", "motion", "tick", "raw_ir"} <= set(infos[a])
        assert infos[a]["period"] == pytest.approx(0.033)
        assert infos[a]["command"] == "D,l19685,l19685"  # 9 cm/s x 218.72 units per mm/s
    assert emu.world.speed_unit == env.speed_units[0]
    sim.close()


def test_motion_matches_the_simulator_tick_for_tick(make_env):
    """Open-loop actions away from walls: the emulated robots follow the simulator's poses."""
    env, emu = make_env()
    sim = patrol_return_v0.parallel_env()
    env.reset()
    sim.reset(seed=0)
    plan = [1] * 20 + [0] * 10 + [1] * 10 + [2] * 25 + [1] * 10
    for a in plan:
        acts = {ag: a for ag in env.possible_agents}
        _, _, _, _, hw = env.step(acts)
        _, _, _, _, si = sim.step(acts)
        for ag in env.possible_agents:
            np.testing.assert_allclose(hw[ag]["pose"][:2], si[ag]["pose"][:2], atol=1e-3)
            assert hw[ag]["pose"][2] == pytest.approx(si[ag]["pose"][2], abs=1e-3)
    sim.close()


def test_reset_hands_placement_to_the_operator(make_env):
    calls = []
    env, emu = make_env()
    env._placement = lambda targets: (calls.append(dict(targets)), emu.place(targets))
    target = (93.5, 120.0, math.pi / 2)
    obs, infos = env.reset(options={"poses": {"robot_1": target}})
    assert calls[0]["robot_1"] == target
    assert calls[0]["robot_0"] == tuple(env.world.starts[0])
    assert infos["robot_1"]["pose"] == pytest.approx(target)
    # robots are told to stop before being handed over
    assert all(last_command(emu, k) == "N" and "D,l0,l0" in emu.commands(k)[-3:] for k in range(3))
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(options={"speed": 3})
    with pytest.raises(ValueError, match="unknown agent"):
        env.reset(options={"poses": {"robot_9": target}})


def test_prompt_placement_asks_and_waits(make_env, monkeypatch):
    prompts = []
    monkeypatch.setattr("builtins.input", lambda text="": prompts.append(text) or "")
    env, emu = make_env(placement="prompt")
    env.reset()
    assert prompts and "Press Enter" in prompts[0]


def test_signal_auto_schedule_and_operator(make_env):
    env, emu = make_env(episode=Episode(max_cycles=40, signal_tick=30, signal_schedule={"robot_2": 5}))
    obs, _ = env.reset()
    assert all(o[6] == 0 for o in obs.values())
    seen = {}
    for t in range(1, 41):
        if t == 3:
            env.call_home("robot_1")
        if t == 10:
            env.clear_signal("robot_1")
        obs, _, _, truncs, infos = env.step({a: 0 for a in env.agents})
        seen[t] = {a: float(obs[a][6]) for a in obs}
    assert seen[3]["robot_1"] == 1.0 and seen[2]["robot_1"] == 0.0
    assert seen[10]["robot_1"] == 0.0
    assert seen[5]["robot_2"] == 1.0 and seen[4]["robot_2"] == 0.0
    assert seen[29]["robot_0"] == 0.0 and all(v == 1.0 for v in seen[30].values())
    assert all(truncs.values()) and "team_fitness" in infos["robot_0"] and env.agents == []
    with pytest.raises(ValueError, match="unknown agent"):
        env.call_home("robot_7")


def test_reflex_on_by_default_and_can_be_turned_off(make_env):
    near_wall = {"robot_0": (93.5, 187.0075 - 8.0, math.pi / 2)}  # 8 cm from the top wall, facing it
    env, emu = make_env()
    env.reset(options={"poses": near_wall})
    _, _, _, _, infos = env.step({a: 1 for a in env.agents})
    assert infos["robot_0"]["motion"] == "stop" and infos["robot_0"]["command"] == "D,l0,l0"
    assert infos["robot_1"]["motion"] == "forward"
    env2, emu2 = make_env(driving=Driving(reflex=False))
    env2.reset(options={"poses": near_wall})
    _, _, _, _, infos = env2.step({a: 1 for a in env2.agents})
    assert infos["robot_0"]["motion"] == "forward"


def test_calibration_and_floor_are_swappable(make_env):
    env, emu = make_env(sensing=Sensing(calibration=lambda raw: np.full(np.shape(raw), 0.2), sensor_floor=0.0))
    obs, _ = env.reset()
    assert np.allclose(obs["robot_0"][:6], 0.2)
    # the default floor 0.25 applies
    env2, _ = make_env(sensing=Sensing(calibration=lambda raw: np.full(np.shape(raw), 0.2)))
    obs, _ = env2.reset()
    assert np.all(obs["robot_0"][:6] == 0.0)
    # the reflex sees the un-floored 0.2 on every sensor: the left branch wins, turning in place
    _, _, _, _, infos = env2.step({a: 1 for a in env2.agents})
    assert infos["robot_0"]["motion"] == "right"


def test_speed_unit_read_from_the_firmware_version(make_env):
    env, emu = make_env(emu_kwargs={"firmware": (2, 7), "speed_unit": SPEED_UNIT_V2},
                        driving=Driving(forward_speed=6.0, turn_rate=1.0))
    assert env.firmware["robot_0"] == (2, 7) and env.speed_units == [SPEED_UNIT_V2] * 3
    env.reset()
    _, _, _, _, infos = env.step({"robot_0": 1, "robot_1": 0, "robot_2": 2})
    assert infos["robot_0"]["command"] == f"D,l{round(60 * SPEED_UNIT_V2)},l{round(60 * SPEED_UNIT_V2)}"
    half = round(1.0 * 8.85 / 2 * 10 * SPEED_UNIT_V2)
    assert infos["robot_1"]["command"] == f"D,l{-half},l{half}"
    assert infos["robot_2"]["command"] == f"D,l{half},l{-half}"
    env2, _ = make_env(driving=Driving(speed_unit=[100.0, 200.0, 300.0]))
    assert env2.speed_units == [100.0, 200.0, 300.0]


def test_episode_end_close_and_context_manager_stop_every_robot(make_env, make_emulator, vclock):
    env, emu = make_env(episode=Episode(max_cycles=5))
    env.reset()
    for _ in range(5):
        env.step({a: 1 for a in env.agents})
    assert env.agents == [] and all(last_command(emu, k) == "D,l0,l0" for k in range(3))
    with pytest.raises(RuntimeError, match="finished episode"):
        env.step({a: 1 for a in env.possible_agents})
    env.reset()
    env.step({a: 1 for a in env.agents})
    assert not emu.world.stopped(0)
    env.close()
    env.close()  # idempotent
    assert all(last_command(emu, k) == "D,l0,l0" and emu.world.stopped(k) for k in range(3))
    with pytest.raises(RuntimeError, match="closed"):
        env.reset()

    emu2 = make_emulator(clock=vclock)
    with KheperaHardwareEnv(emu2.ports, timing=Timing(clock=vclock), poses=Poses(placement="none"),
                            catch_sigterm=False) as env2:
        env2.reset()
        env2.step({a: 2 for a in env2.agents})
        assert not emu2.world.stopped(1)
    assert all(emu2.world.stopped(k) for k in range(3))


def test_any_exception_in_step_stops_every_robot(make_env):
    env, emu = make_env()
    env.reset()
    env.step({a: 1 for a in env.agents})
    with pytest.raises(ValueError, match="robot_1"):
        env.step({"robot_0": 1, "robot_1": 7, "robot_2": 1})
    assert all(emu.world.stopped(k) for k in range(3))
    assert env.agents == []  # the episode is over; reset to go on


def test_ctrl_c_in_step_and_in_reset_stops_every_robot(make_env):
    ticks = {"n": 0}

    def tracker():
        ticks["n"] += 1
        if ticks["n"] == 4:
            raise KeyboardInterrupt
        return emu.poses()

    env, emu = make_env(pose_source=tracker)
    env.reset()
    env.step({a: 1 for a in env.agents})
    env.step({a: 1 for a in env.agents})
    assert not emu.world.stopped(0)
    with pytest.raises(KeyboardInterrupt):
        env.step({a: 1 for a in env.agents})
    assert all(emu.world.stopped(k) for k in range(3))
    assert env.last_stop_report == {"robot_0": None, "robot_1": None, "robot_2": None}

    def impatient(targets):
        raise KeyboardInterrupt

    env2, emu2 = make_env(placement=impatient)
    with pytest.raises(KeyboardInterrupt):
        env2.reset()
    assert all(emu2.world.stopped(k) for k in range(3))


def test_construction_errors():
    with pytest.raises(ValueError, match="non-empty list"):
        KheperaHardwareEnv("socket://127.0.0.1:4000")
    with pytest.raises(ValueError, match="pose_source"):
        KheperaHardwareEnv(["socket://127.0.0.1:4000"], render_mode="rgb_array")
    with pytest.raises(ValueError, match="placement"):
        KheperaHardwareEnv(["socket://127.0.0.1:4000"], poses=Poses(placement="sometimes"))
    with pytest.raises(LinkError, match="robot_0.*cannot open"):
        KheperaHardwareEnv(["socket://127.0.0.1:1"], poses=Poses(placement="none"), catch_sigterm=False,
                           link=Link(retry=RetryPolicy(timeout=0.2)))


def test_render_rgb_array_with_a_tracker(make_env):
    env, _ = make_env(render_mode="rgb_array")
    env.reset()
    env.step({a: 1 for a in env.agents})
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3
    assert np.all(np.isfinite(env.state()))


def test_firmware_without_B_falls_back_to_the_default_speed_unit():
    from .test_transport import FakePort

    def opener(url, timeout, baudrate):
        return FakePort([b"$\r\n", b"m\r\n", b"d\r\n", b"d\r\n"], timeout)

    with pytest.warns(UserWarning, match="does not answer B"):
        env = KheperaHardwareEnv(["fake://0"], poses=Poses(placement="none"), catch_sigterm=False,
                                 link=Link(opener=opener))
    assert env.firmware == {"robot_0": None} and env.speed_units == [218.72]
    env.close()
    env = KheperaHardwareEnv(["fake://0"], poses=Poses(placement="none"), catch_sigterm=False,
                             link=Link(opener=opener), driving=Driving(speed_unit=150.0))
    assert env.speed_units == [150.0]
    env.close()


def test_the_input_ceiling_reads_near_open_values_as_open_on_robots(make_env):
    """Sensing.input_ceiling (TaskParams.input_ceiling): a calibrated 0.96 reads 1 with a ceiling of 0.95, and
    stays 0.96 with the original's encoding."""
    def near_open(raw):
        return np.full(np.shape(raw), 0.96)

    env, _ = make_env(sensing=Sensing(calibration=near_open, input_ceiling=0.95))
    obs, _ = env.reset()
    assert np.all(obs["robot_0"][:6] == 1.0)
    env2, _ = make_env(sensing=Sensing(calibration=near_open))
    obs, _ = env2.reset()
    assert np.allclose(obs["robot_0"][:6], 0.96) and np.all(obs["robot_0"][:6] < 1.0)
