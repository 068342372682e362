"""The sequential protocol in the batch core (mahn_envs.core.sequential) against the env-driven protocol.

The kernel is what evolution will be scored on, the env-driven protocol what the transfer test plays: with the
same team, seed and engine (kinematic) every record must be equal, tick for tick.
"""
from __future__ import annotations

import numpy as np
import pytest

from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.core.sequential import (
    REC_CALL_END,
    REC_CALLED,
    REC_LEFT,
    REC_POST,
    S_HOME,
    S_OUT,
    S_POST,
    S_STOOD,
    SequentialSettings,
    assign_posts,
    call_order,
    play_sequential,
    sequential_task,
    stopped,
)
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.evaluation.protocols import sequential_episode
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.champion import Champion
from tests.envs.helpers import BRITTLE_TEAM, ROBUST_TEAM, random_team

ROBUST, BRITTLE = ROBUST_TEAM, BRITTLE_TEAM


def _python_records(controllers, params, seed, map_name="plus", settings=None):
    agents = [f"robot_{k}" for k in range(controllers.n_robots)]
    res = sequential_episode(ControllerPolicy(controllers, agents), map=map_name, params=params, seed=seed,
                             settings=settings, engine="kinematic")
    records = [[-1 if r.left_tick is None else r.left_tick, r.post, r.called_tick, r.call_end_tick]
               for r in res.robots]
    stages = [[r.reached_post, r.returned_home, r.went_back_out, r.stood_when_called] for r in res.robots]
    return res, np.array(records), np.array(stages)


@pytest.mark.parametrize("path", [ROBUST, BRITTLE], ids=["robust", "brittle"])
def test_kernel_plays_the_env_protocol_record_for_record(path):
    champ = Champion.load(path)
    noisy = champ.task(task_params("generalization"))
    for seed in (1, 2):
        res, records, stages = _python_records(champ.controllers, noisy, seed)
        out = play_sequential("plus", champ.controllers, noisy, seed=seed)
        assert np.array_equal(out.records[0], records) and np.array_equal(out.stages[0], stages)
        assert out.ticks[0] == res.ticks and out.success[0] == res.success
        assert out.stages_completed[0] == res.stages_completed and out.score[0] == pytest.approx(res.score)
    # the robust team succeeds in both episodes, the brittle one in neither (these seeds)
    assert play_sequential("plus", champ.controllers, noisy, seed=1).success[0] == (path == ROBUST)


def test_under_the_robot_noise_the_kernel_still_plays_the_env_protocol():
    """The Khepera sensors and a reflex reading them (`--noise robot`), in the kernel and through the env."""
    champ = Champion.load(ROBUST)
    robot = champ.task(task_params("robot"))
    res, records, stages = _python_records(champ.controllers, robot, 3)
    out = play_sequential("plus", champ.controllers, robot, seed=3)
    assert np.array_equal(out.records[0], records) and np.array_equal(out.stages[0], stages)
    assert out.ticks[0] == res.ticks and out.success[0] == res.success


def test_a_batch_of_teams_is_each_team_alone_and_other_sizes_and_maps_agree():
    """Team b in episode b equals the team played alone; a network size without the packed fast path (5
    hidden units) and the test map give the env protocol's records too (short settings: random teams)."""
    short = SequentialSettings(patrol_ticks=300, return_ticks=200, out_ticks=200)
    params = task_params("generalization")
    robust, brittle = Champion.load(ROBUST).controllers, Champion.load(BRITTLE).controllers
    from mahn_envs.policies.team_controllers import TeamControllers

    both = TeamControllers(*(np.stack([getattr(robust, f), getattr(brittle, f)])
                             for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))
    batch = play_sequential("plus", both, params, seed=3, episode_keys=[0, 0])
    for b, team in enumerate((robust, brittle)):
        alone = play_sequential("plus", team, params, seed=3)
        assert np.array_equal(batch.records[b], alone.records[0]) and np.array_equal(batch.stages[b], alone.stages[0])
    rng = np.random.default_rng(0)
    small = TeamControllers(*(rng.normal(0, 1.5, shape) for shape in ((3, 2, 5, 7), (3, 2, 5, 5), (3, 2, 3, 5),
                                                                     (3, 2, 5), (3, 2, 3))))
    for team, map_name in ((small, "plus"), (random_team(4), "asymmetric_plus")):
        _, records, stages = _python_records(team, params, 5, map_name, short)
        out = play_sequential(map_name, team, params, settings=short, seed=5)
        assert np.array_equal(out.records[0], records) and np.array_equal(out.stages[0], stages)


def test_the_rules():
    # stopped: the ring holds the positions after the last window + 1 ticks
    ring = np.zeros((4, 1, 2))
    for t, x in enumerate([0.0, 5.0, 5.2, 5.4, 5.6, 9.0], start=1):
        ring[t % 4, 0, 0] = x
        if t == 3:
            assert not stopped(ring, t, 0, 3, 1.0)  # too few ticks yet
        if t == 5:
            assert stopped(ring, t, 0, 3, 1.0)  # 5.0 -> 5.6 over 3 ticks
    assert not stopped(ring, 6, 0, 3, 1.0)  # 5.2 -> 9.0
    # posts: the nearest POI (Manhattan); two robots that reached one post: the first keeps it
    pois = np.array([[0.0, 0.0], [100.0, 0.0], [0.0, 100.0]])
    post, reached = np.zeros(3, dtype=np.int64), np.zeros(3, dtype=np.bool_)
    assign_posts(np.array([[3.0, 2.0], [98.0, 9.0], [2.0, 1.0]]), pois, post, reached)
    assert post.tolist() == [0, 1, 0] and reached.tolist() == [True, True, False]
    assign_posts(np.array([[30.0, 0.0], [5.0, 0.0], [0.0, 99.0]]), pois, post, reached)
    assert post.tolist() == [0, 0, 2] and reached.tolist() == [False, True, True]  # no two reached it: kept
    # call order: by the tick they left, robots that never left last, ties by index
    order = np.zeros(4, dtype=np.int64)
    call_order(np.array([40, -1, 12, 40]), order)
    assert order.tolist() == [2, 0, 3, 1]
    assert (REC_LEFT, REC_POST, REC_CALLED, REC_CALL_END) == (0, 1, 2, 3)
    assert (S_POST, S_HOME, S_OUT, S_STOOD) == (0, 1, 2, 3)


def test_bad_settings_and_a_sim_without_the_protocols_task_are_clear_errors():
    with pytest.raises(ValueError, match="return_ticks must be a positive integer"):
        SequentialSettings(return_ticks=0)
    with pytest.raises(ValueError, match="stop_distance must be a positive number"):
        SequentialSettings(stop_distance=float("nan"))
    with pytest.raises(ValueError, match="needs the protocol's task"):
        BatchSim("plus", 1).run_sequential(random_team(1))
    sim = BatchSim("plus", 2, sequential_task(TaskParams(), SequentialSettings()))
    with pytest.raises(ValueError, match="3 teams for 2 episodes"):
        from mahn_envs.policies.team_controllers import TeamControllers

        teams = [random_team(s) for s in range(3)]
        sim.run_sequential(TeamControllers(*(np.stack([getattr(t, f) for t in teams])
                                             for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o"))))


def test_max_lost_stops_an_episode_once_it_lost_more_stages_and_changes_nothing_else():
    """An episode allowed exactly the stages it loses plays as without a limit; allowed one fewer, it stops
    early (`cut`) with the stages it had done by then, a subset of the full episode's."""
    from mahn_envs.policies.team_controllers import TeamControllers

    params = task_params("generalization")
    robust, brittle = Champion.load(ROBUST).controllers, Champion.load(BRITTLE).controllers
    teams = [robust, brittle] + [random_team(s) for s in range(4)]
    batch = TeamControllers(*(np.stack([getattr(t, f) for t in teams]) for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))
    keys = [7] * len(teams)
    sim = BatchSim("plus", len(teams), sequential_task(params, SequentialSettings()))
    full = sim.run_sequential(batch, seed=2, episode_keys=keys)
    lost = 9 - full.stages_completed
    assert not full.cut.any() and lost.min() == 0 and lost.max() > 1  # a success and a failure in the batch
    same = sim.run_sequential(batch, seed=2, episode_keys=keys, max_lost=lost)
    assert not same.cut.any() and np.array_equal(same.records, full.records)
    assert np.array_equal(same.stages, full.stages) and np.array_equal(same.ticks, full.ticks)
    for limit in (np.maximum(lost - 1, 0), np.zeros_like(lost)):  # stopped at the last loss, at the first
        fewer = sim.run_sequential(batch, seed=2, episode_keys=keys, max_lost=limit)
        assert np.array_equal(fewer.cut, lost > 0) and (fewer.ticks <= full.ticks).all()
        done, done_full = fewer.stages[:, :, :3], full.stages[:, :, :3]
        assert not (done & ~done_full).any()  # nothing done that the full episode did not do
        assert np.array_equal(fewer.records[~fewer.cut], full.records[~fewer.cut])
    assert (fewer.ticks[lost > 0] < full.ticks[lost > 0]).all()  # a first loss comes before the end
    for bad in ([1, 2], lost - 10, lost.astype(float)):
        with pytest.raises(ValueError, match="max_lost must hold one non-negative integer per episode"):
            sim.run_sequential(batch, seed=2, episode_keys=keys, max_lost=bad)
