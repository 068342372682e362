"""The core's public API (mahn_envs.core.api) against the compiled kernels on real episodes: each function must
give exactly what the batch core computes, since the env, the pymunk engine, the hardware env and the emulator
use it instead of writing the rules again."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mahn_envs.core import (
    Arena,
    BatchSim,
    ScoreKeeper,
    TaskParams,
    encode_inputs,
    policy_coordinates,
    readings_from_ranges,
    steer,
)
from mahn_envs.core import task as T
from mahn_envs.core.api import NO_TURN, TURN_LEFT, TURN_RIGHT
from mahn_envs.khepera import DEFAULT_MODEL
from mahn_envs.patrol_return.env import agent_names, agent_policy_coordinates

#: mahn 0.1's published champions, whose exact fitness is pinned
PUBLISHED = Path(__file__).parents[2] / "docs" / "results" / "experiment_mahn_0.1" / "champions"
CHAMPIONS = sorted(PUBLISHED.glob("*.json"))


def _champions():
    from mahn_evo.training.champion import Champion

    champs = [Champion.load(p) for p in CHAMPIONS]
    teams = [c.controllers for c in champs if c.controllers.w_ih.shape[1] == 2]  # situational: the return works
    return type(teams[0])(*(np.stack([getattr(t, f) for t in teams]) for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))


@pytest.mark.parametrize("noisy", [False, True])
def test_score_keeper_scores_recorded_trajectories_as_the_kernel(noisy):
    """Scoring the recorded poses tick by tick through the API gives the kernel's fitness bit for bit."""
    params = TaskParams(**(dict(sensor_noise=5.0, effector_noise=10.0, heading_noise=0.005) if noisy else {}))
    ctrl = _champions()
    res = BatchSim("plus", ctrl.w_ih.shape[0], params).run_controllers(ctrl, seed=4, record=True)
    assert res.trajectories is not None and res.solved.any()  # a solved team: every term of the fitness counts
    for b in range(ctrl.w_ih.shape[0]):
        keeper = ScoreKeeper("plus", params)
        keeper.reset(res.trajectories[b, 0, :, :3])
        for t in range(1, params.max_cycles + 1):
            keeper.advance(res.trajectories[b, t, :, :3])
            assert keeper.signals.tolist() == ([1, 1, 1] if t >= params.signal_tick else [0, 0, 0])
        assert keeper.fitness() == (res.fitness[b], bool(res.solved[b]))


def test_score_keeper_without_poses_runs_only_the_signal_schedule():
    keeper = ScoreKeeper("plus", TaskParams(max_cycles=100, signal_tick=60, sample_period=30))
    for _ in range(60):
        assert keeper.signals.tolist() == [0, 0, 0]
        keeper.advance()
    assert keeper.tick == 60 and keeper.signals.tolist() == [1, 1, 1]
    with pytest.raises(RuntimeError, match="poses of every tick"):
        keeper.fitness()
    off = ScoreKeeper("plus", TaskParams(auto_signal=False))
    for _ in range(700):
        off.advance()
    assert off.signals.tolist() == [0, 0, 0]
    off.set_signal(1)
    assert off.signals.tolist() == [0, 1, 0]
    with pytest.raises(ValueError, match="poses must have shape"):
        off.advance(np.zeros((2, 3)))


@pytest.mark.parametrize("see", [False, True])
def test_arena_ranges_and_encode_inputs_give_the_core_observations(see):
    """Ray casts from the poses, their readings and the input encoding reproduce the core's obs every tick."""
    params = TaskParams(max_cycles=400, signal_tick=240, robots_see_each_other=see)
    sim = BatchSim("plus", 1, params)
    obs = sim.reset(seed=2)
    rng = np.random.default_rng(5)
    arena = sim.arena
    n_floored = 0
    while not sim.done:
        pose = sim.pose[0]
        for r in range(sim.n_robots):
            others = np.delete(pose[:, :2], r, axis=0) if see else None
            assert np.array_equal(arena.ranges(*pose[r, :3], others), sim.raw[0, r])
        readings = readings_from_ranges(sim.raw[0])
        expected = encode_inputs(readings, sim.rflag[0, :, T.F_SIGNAL])
        assert np.array_equal(expected, obs[0])
        n_floored += int(np.sum((expected[:, :6] == 0) & (readings > 0)))
        obs, _, _ = sim.step(rng.choice(3, size=(1, 3), p=[0.2, 0.6, 0.2]))
    assert n_floored > 0  # the floor was really exercised


def test_encode_inputs_caps_floors_and_checks_shapes():
    out = encode_inputs([[1.5, 0.25, 0.2501, 0.0, 0.7, 1.0]], [1.0], floor=0.25)
    assert out.dtype == np.float32
    assert out.tolist() == [[1.0, 0.0, float(np.float32(0.2501)), 0.0, float(np.float32(0.7)), 1.0, 1.0]]
    with pytest.raises(ValueError, match="readings"):
        encode_inputs([[1.0] * 5], [0.0])
    with pytest.raises(ValueError, match="signal"):
        encode_inputs([[1.0] * 6], [0.0, 1.0])


def _decide(action: int, raw: np.ndarray, velocity: float, reflex: bool,
            arc: bool = False) -> tuple[float, float, bool]:
    """The core's decide_robot on one robot: (heading change, velocity, corrected)."""
    params = TaskParams(reflex=reflex, reflex_arc=arc).vector(DEFAULT_MODEL)
    pose = np.zeros((1, 1, 4))
    pose[0, 0, 3] = velocity
    corrected = T.decide_robot(0, 0, action, 1, pose, raw.reshape(1, 1, 6).astype(np.float64),
                               np.ones((1, 1, 7), np.float32), params, 0, np.uint64(0))
    return pose[0, 0, 2], pose[0, 0, 3], corrected


@pytest.mark.parametrize("reflex, arc", [(True, False), (False, False), (True, True)])
def test_steer_matches_decide_robot_on_a_grid_of_readings(reflex, arc):
    rng = np.random.default_rng(11)
    threshold = DEFAULT_MODEL.radius + DEFAULT_MODEL.sensor_floor * DEFAULT_MODEL.ir_range
    step = DEFAULT_MODEL.turn_step
    seen = set()
    for _ in range(3000):
        # mostly near the floor, where an off-by-one comparison would show
        raw = np.where(rng.random(6) < 0.7, threshold + rng.normal(0, 0.3, 6), rng.uniform(6.5, 16.66, 6))
        raw = np.clip(raw, 6.5, 16.66)
        action = int(rng.integers(0, 3))
        velocity = float(rng.choice([0.0, DEFAULT_MODEL.speed]))
        dh, v, corrected = _decide(action, raw, velocity, reflex, arc)
        turn, v_api = steer(action, readings_from_ranges(raw), velocity, reflex=reflex, arc=arc)
        assert (turn * step, v_api) == (dh, v), (action, raw.tolist(), velocity)
        assert corrected == (action == T.FORWARD and turn == NO_TURN and v_api == 0.0)
        seen.add((action, turn, v_api > 0))
    if arc:  # the arcing reflex: a side branch drives whether the robot stood or drove
        assert {(1, TURN_RIGHT, True), (1, NO_TURN, False), (1, TURN_LEFT, True), (1, NO_TURN, True)} <= seen
        assert not {(1, TURN_RIGHT, False), (1, TURN_LEFT, False)} & seen
    elif reflex:  # every reflex branch, driving and standing: left, front, right blocked
        assert {(1, TURN_RIGHT, True), (1, TURN_RIGHT, False), (1, NO_TURN, False), (1, TURN_LEFT, True),
                (1, TURN_LEFT, False), (1, NO_TURN, True)} <= seen
    with pytest.raises(ValueError, match="action"):
        steer(3, [1.0] * 6, 0.0)
    with pytest.raises(ValueError, match="six"):
        steer(1, [1.0] * 5, 0.0)


def test_split_tick_with_arena_move_equals_the_kernel_step():
    """An engine that moves robots itself (begin_tick, Arena.move, move_robot_to, end_tick) reproduces the
    compiled step exactly when it moves them as the core does, wall contacts included."""
    params = TaskParams(max_cycles=600, signal_tick=300, reflex=False)  # without the reflex robots hit walls
    kernel, split = BatchSim("plus", 1, params), BatchSim("plus", 1, params)
    kernel.reset(seed=1)
    split.reset(seed=1)
    rng = np.random.default_rng(3)
    dt = DEFAULT_MODEL.dt_robot
    touched = 0
    while not kernel.done:
        actions = rng.choice(3, size=(1, 3), p=[0.1, 0.8, 0.1])
        obs_k, rew_k, solved_k = kernel.step(actions)
        split.begin_tick(actions)
        for r in range(3):
            x, y, h, v = split.pose[0, r]
            nx, ny, hit = split.arena.move(x, y, x + math.cos(h) * (v * dt), y + math.sin(h) * (v * dt))
            touched += hit
            assert split.move_robot_to(0, r, x + math.cos(h) * (v * dt), y + math.sin(h) * (v * dt)) == (not hit)
            assert (split.pose[0, r, 0], split.pose[0, r, 1]) == (nx, ny)
        obs_s, rew_s, solved_s = split.end_tick()
        assert np.array_equal(kernel.pose, split.pose) and np.array_equal(obs_k, obs_s)
        assert np.array_equal(rew_k, rew_s) and np.array_equal(solved_k, solved_s)
    assert touched > 0
    assert np.array_equal(kernel.racc, split.racc)  # collisions counted alike
    with pytest.raises(RuntimeError, match="over"):
        split.begin_tick(np.ones((1, 3), dtype=np.int64))


def test_arena_accessors_and_wall_rule():
    arena = Arena("plus")
    sim = BatchSim("plus", 1)
    for name in ("walls", "boxes", "sensor_dirs", "pois", "home"):
        assert np.array_equal(getattr(arena, name), getattr(sim.arena, name))
    x, y, _ = sim.world.starts[0]
    assert not arena.touches_wall(x, y)
    assert arena.move(x, y, x + 1.0, y) == (x + 1.0, y, False)
    wx, wy = (arena.walls[0, :2] + arena.walls[0, 2:]) / 2.0  # onto a wall: refused, the robot stays
    assert arena.touches_wall(wx, wy)
    assert arena.move(x, y, wx, wy) == (x, y, True)


@pytest.mark.parametrize("n", [1, 3, 4, 5])
def test_policy_coordinates_are_the_substrates(n):
    """The env's z (agent_policy_coordinates) is the one the trainer paints brains at (the substrate's queries)."""
    from mahn_evo.hyperneat.substrate import query_layout

    zs = list(agent_policy_coordinates(agent_names(n)).values())
    assert zs == policy_coordinates(n).tolist()
    layout = query_layout("standard", n)
    assert layout.queries[layout.q_bh[:, 0, 0], 4].tolist() == zs
    assert policy_coordinates(3).tolist() == [-1.0, 0.0, 1.0]
    with pytest.raises(ValueError, match="n_robots"):
        policy_coordinates(0)



def test_the_task_radii_and_distance_are_the_cores():
    """The protocols measure home and posts with the fitness's own rule (Manhattan, radii 20 and 15)."""
    from mahn_envs.core import task
    from mahn_envs.core.api import HOME_REACHED, POST_REACHED, manhattan
    assert (HOME_REACHED, POST_REACHED) == (task.HOME_REACHED, task.POI_CLOSE) == (20.0, 15.0)
    assert manhattan((1.0, 2.0), (4.0, -2.5)) == 7.5
