"""Sensors as a real robot has them, beyond the original (TaskParams.sensor_model, TaskParams.reflex_reads_noise).

"khepera" turns each ray into a 12-bit count by the paper's calibration, with a real Khepera III's Gaussian relative
noise, rounded and calibrated back, as the emulator answers `N`; with reflex_reads_noise the collision-avoidance
reflex reads those noisy values, as a robot's reflex reads its sensors, where the original's simulated reflex
reads the noise-free rays.  The defaults are the original's and leave every result bit for bit as it was (the
identity tests); these tests check that the new model is the emulator's and that the reflex really reads the noise.
"""
from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from scipy import stats

from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.core.task import P_RANGE, P_RNOISE, P_SMODEL, UNIT_OF_COUNT, encode_episode, khepera_unit, unit_of_count
from mahn_envs.hardware.calibration import PAPER
from mahn_envs.hardware.clock import VirtualClock
from mahn_envs.hardware.emulated_world import EmulatedWorld
from mahn_envs.hardware.protocol import FRONT_SENSORS
from mahn_envs.khepera import IR_CALIBRATION_A, IR_CALIBRATION_B, IR_CALIBRATION_C, IR_RAW_MAX
from mahn_envs.patrol_return_v0 import parallel_env
from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.evaluation.task_setup import NOISE_PRESETS, task_params
from mahn_evo.training.config import EvolutionConfig

FORWARD = 1


def test_the_defaults_are_the_originals_sensors_and_reflex():
    p = TaskParams()
    assert p.sensor_model == "uniform" and p.reflex_reads_noise is False
    v = p.vector()
    assert v[P_SMODEL] == 0.0 and v[P_RNOISE] == 0.0


@pytest.mark.parametrize("field, bad, error", [("sensor_model", "webots", ValueError),
                                               ("reflex_reads_noise", "yes", TypeError)])
def test_bad_settings_are_refused_naming_the_field(field, bad, error):
    with pytest.raises(error, match=field):
        TaskParams(**{field: bad})


def test_noise_free_khepera_readings_are_the_emulators_counts_calibrated_back():
    """Without noise the model is deterministic: the emulator's count for each ray (rounded to an integer),
    through the paper's calibration, as the hardware env reads it."""
    params = TaskParams(sensor_model="khepera")
    sim = BatchSim("plus", 1, params)
    obs = sim.reset(seed=0)
    world = EmulatedWorld("plus", noise=0.0, clock=VirtualClock())
    for k in range(3):
        counts = np.asarray(world.proximity(k))[list(FRONT_SENSORS)]
        unit = PAPER.to_unit(counts)
        expected = np.where(unit <= 0.25, 0.0, np.minimum(unit, 1.0)).astype(np.float32)
        np.testing.assert_array_equal(obs[0, k, :6], expected)
    # the same rays through the uniform model read differently (rounding counts moves values near the range edge)
    plain = BatchSim("plus", 1, TaskParams()).reset(seed=0)
    assert not np.array_equal(plain[0, :, :6], obs[0, :, :6])


def test_noisy_khepera_readings_follow_the_emulators_noise():
    """At a fixed gap the core's readings (one per episode key) and the emulator's (one per N) come from the same
    distribution: a real sensor's relative Gaussian noise on the count."""
    gap = 4.0  # cm: sigma 0.27 of the count, the noisiest part of the table
    n = 4000
    core = np.array([khepera_unit(gap, 10.16, 1.0, g) for g in np.random.default_rng(1).standard_normal(n)])
    counts = PAPER.to_raw(gap / 10.16) * (1.0 + 0.27 * np.random.default_rng(0).standard_normal(n))
    emulator = PAPER.to_unit(np.clip(np.rint(counts), 0, 4095))
    assert stats.ks_2samp(core, emulator).pvalue > 0.01
    assert 0.04 < core.std() < 0.07  # about 0.193 x 0.27 in unit terms: twice the +-5 % uniform noise's sd
    # the core's Gaussians (Box-Muller pairs from the counter-based stream) are standard normal: a sensor at that
    # gap read over many episode keys spreads as the emulator's readings do
    params = TaskParams(sensor_model="khepera", sensor_noise=100.0).vector()
    raw = np.full((n, 1, 6), 6.5 + gap)  # every sensor of one robot `gap` cm from a wall, in n episodes (keys)
    read = _encoded(raw, params, 5).astype(np.float64)
    for j in range(6):
        assert stats.ks_2samp(read[:, 0, j], emulator).pvalue > 0.001


@njit
def _encoded(raw, params, seed):
    """The core's inputs for ray distances raw (B, R, 6), episode b with key b, tick 1."""
    obs = np.zeros((raw.shape[0], raw.shape[1], 7), dtype=np.float32)
    rflag = np.zeros((raw.shape[0], raw.shape[1], 3), dtype=np.uint8)
    for b in range(raw.shape[0]):
        encode_episode(b, 1, raw, obs, rflag, params, seed, np.uint64(b))
    return obs


def test_khepera_readings_are_drawn_from_the_episodes_stream():
    """The core draws its Gaussians from the episode's counter-based stream: the same key, the same readings."""
    sim = BatchSim("plus", 2, TaskParams(sensor_model="khepera", sensor_noise=100.0))
    a = sim.reset(seed=3, episode_keys=[7, 7]).copy()
    assert np.array_equal(a[0], a[1])
    assert not np.array_equal(a[0], sim.reset(seed=3, episode_keys=[8, 8])[0])


def test_the_count_table_is_the_calibration_formula():
    """The readings look a rounded count up (UNIT_OF_COUNT) instead of taking its logarithm: the table holds the
    formula's value for every count, and a ray that hit nothing reads as one at the range's gap."""
    counts = np.arange(1, IR_RAW_MAX + 1, dtype=np.float64)
    formula = np.clip(IR_CALIBRATION_A - (np.log(counts) / np.log(10.0) - IR_CALIBRATION_B) / IR_CALIBRATION_C, 0, 1)
    np.testing.assert_allclose(UNIT_OF_COUNT[1:], formula, rtol=0, atol=1e-15)
    assert all(UNIT_OF_COUNT[k] == unit_of_count(float(k)) for k in (1, 2, 17, 1000, IR_RAW_MAX))
    params = TaskParams(sensor_model="khepera", sensor_noise=100.0).vector()
    free = np.full((64, 1, 6), params[P_RANGE])
    near_free = np.full((64, 1, 6), np.nextafter(params[P_RANGE], 0.0))  # the same gap within 2e-15, but hit
    np.testing.assert_array_equal(_encoded(free, params, 4), _encoded(near_free, params, 4))


def _headings_at_a_wall(**task) -> np.ndarray:
    """Headings of robots that always ask to go forward, once they stand at the end of their arm."""
    params = TaskParams(max_cycles=700, signal_tick=690, **task)
    sim = BatchSim("plus", 8, params)
    sim.reset(seed=2, episode_keys=np.arange(8))
    forward = np.full((8, 3), FORWARD)
    heads = []
    while not sim.done:
        sim.step(forward)
        if sim.tick > 600:
            heads.append(sim.pose[:, :, 2].copy())
    return np.array(heads)


def test_the_reflex_reads_the_sensor_noise_only_when_told():
    """Forward into a dead end: the original's reflex reads the noise-free rays, so a robot that reached the wall
    stands still for good whatever the noise on its inputs; a reflex that reads the noisy values sometimes sees a
    wall close on one side (the side walls read about 0.85, the noise here reaches 0.25) and turns away."""
    for noisy in (dict(sensor_noise=80.0), dict(sensor_noise=400.0, sensor_model="khepera")):
        still = _headings_at_a_wall(**noisy)
        assert np.all(still == still[0])  # no heading noise: nothing turns a standing robot
        turned = _headings_at_a_wall(reflex_reads_noise=True, **noisy)
        assert np.any(turned != turned[0])
    # without sensor noise the switch changes nothing
    assert np.array_equal(_headings_at_a_wall(sensor_model="khepera"),
                          _headings_at_a_wall(sensor_model="khepera", reflex_reads_noise=True))


def test_the_robot_noise_preset_names_itself_and_without_noise_is_the_original_world():
    assert NOISE_PRESETS["robot"]["sensor_model"] == "khepera"
    robot = task_params("robot")
    assert robot.reflex_reads_noise and robot.sensor_noise == 100.0
    assert EvolutionConfig().with_noise("robot").noise_preset == "robot"
    assert EvolutionConfig().with_noise("generalization").noise_preset == "generalization"
    assert robot.without_noise() == TaskParams()
    sensors = robot.only_noise("sensor_noise")
    assert (sensors.sensor_model, sensors.reflex_reads_noise, sensors.effector_noise) == ("khepera", True, 0.0)
    assert robot.only_noise("heading_noise").sensor_model == "uniform"


def test_the_pettingzoo_env_takes_the_robot_sensors():
    env = parallel_env(map="plus", sensor_noise=100.0, sensor_model="khepera", reflex_reads_noise=True)
    obs, _ = env.reset(seed=1)
    assert env.unwrapped.params.sensor_model == "khepera"
    assert all(o.dtype == np.float32 and o.shape == (7,) for o in obs.values())


def _robot_pilot_teams():
    from pathlib import Path

    from mahn_evo.training.champion import Champion

    folder = Path(__file__).resolve().parents[2] / "docs" / "results" / "robot_pilot" / "champions"
    return [Champion.load(p).controllers for p in sorted(folder.glob("situational_s0*.json"))[:3]]


def test_episodes_on_a_shared_key_read_the_gaussians_they_would_draw_alone():
    """Under the robot noise, episodes that share a key (a generation's common random numbers) read their sensor
    Gaussians from one table (BatchSim._share_sensor_gaussians); each must play exactly as alone, where it draws
    them itself: whole episodes of the training protocol and of the sequential protocol."""
    from mahn_envs.core.sequential import play_sequential

    params = task_params("robot")
    teams = _robot_pilot_teams()
    assert len(teams) == 3
    batch = TeamControllers.stack(teams)
    sim = BatchSim("plus", 3, params)
    shared = sim.run_controllers(batch, seed=11, episode_keys=[5, 5, 5], record=True)
    assert sim._gauss_rows.tolist() == [0, 0, 0] and sim._gauss.shape[0] == 1  # the table was read
    for i, team in enumerate(teams):
        alone_sim = BatchSim("plus", 1, params)
        alone = alone_sim.run_controllers(team, seed=11, episode_keys=[5], record=True)
        assert alone_sim._gauss_rows.tolist() == [-1]  # ... and here each draw computed in the episode
        np.testing.assert_array_equal(shared.trajectories[i], alone.trajectories[0])
        assert shared.fitness[i] == alone.fitness[0]
    seq = play_sequential("plus", batch, params, seed=4, episode_keys=[2, 2, 2])
    for i, team in enumerate(teams):
        one = play_sequential("plus", team, params, seed=4, episode_keys=[2])
        np.testing.assert_array_equal(seq.records[i], one.records[0])
        np.testing.assert_array_equal(seq.stages[i], one.stages[0])
        assert seq.ticks[i] == one.ticks[0]


def test_only_shared_keys_get_a_table_and_the_uniform_model_none():
    sim = BatchSim("plus", 5, task_params("robot"))
    sim.reset(seed=3, episode_keys=[9, 4, 9, 7, 4])
    assert sim._gauss.shape[:2] == (2, sim.params.max_cycles + 2)
    rows = sim._gauss_rows.tolist()
    assert rows[3] == -1 and rows[0] == rows[2] >= 0 and rows[1] == rows[4] >= 0 and rows[0] != rows[1]
    plain = BatchSim("plus", 5, task_params("generalization"))
    plain.reset(seed=3, episode_keys=[1, 1, 1, 1, 1])
    assert plain._gauss_rows.tolist() == [-1] * 5
