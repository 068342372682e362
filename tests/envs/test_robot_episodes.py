"""Robot episodes (BatchSim.run_robot_episodes, score_teams): with robots blind to each other, a team's episode
assembled from its robots' episodes, played in other batches, other episodes and other company, is its own episode
bit for bit: fitness, solved and where every robot ends.  The trainer relies on it to play a genome's mirror
readings with 5 robot episodes instead of 9 (TeamEvaluator._play_training)."""
import numpy as np
import pytest

from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.maps.variants import spread_variant
from mahn_envs.policies.team_controllers import TeamControllers

GENERALIZATION = dict(sensor_noise=5.0, effector_noise=10.0, heading_noise=0.005, start_jitter_xy=2.0,
                      start_jitter_heading=0.1)
ROBOT = {**GENERALIZATION, "sensor_noise": 100.0, "sensor_model": "khepera", "reflex_reads_noise": True}


def teams(n: int, seed: int = 1) -> TeamControllers:
    """Random situational teams whose robots drive about (weights large enough to act on their inputs)."""
    rng = np.random.default_rng(seed)
    return TeamControllers(rng.normal(0, 1.5, (n, 3, 2, 9, 7)), rng.normal(0, 1.5, (n, 3, 2, 9, 9)),
                           rng.normal(0, 1.5, (n, 3, 2, 3, 9)), rng.normal(0, 1.5, (n, 3, 2, 9)),
                           rng.normal(0, 1.5, (n, 3, 2, 3)))


@pytest.mark.parametrize("noise", [{}, GENERALIZATION, ROBOT], ids=["noise-free", "generalization", "robot"])
@pytest.mark.parametrize("world", ["plus", "variant"])
def test_teams_assembled_from_robot_episodes_are_their_own_episodes(noise, world):
    n = 10
    arena = spread_variant(3, 7, 0.0, 49.0, "one_short") if world == "variant" else "plus"
    params = TaskParams(**noise)
    ctrl = teams(n)
    keys = np.arange(n) % 3
    own = BatchSim(arena, n, params)
    res = own.run_controllers(ctrl, seed=11, episode_keys=keys)
    assert len(np.unique(np.round(res.fitness, 6))) > 3  # the teams differ: the test can tell them apart
    # every robot in an episode of its own, in reverse batch order, beside nothing but its own team's row
    order = [(t, r) for t in reversed(range(n)) for r in (2, 0, 1)]
    rows = np.array([t for t, _ in order])
    sim = BatchSim(arena, len(order), params)
    played = sim.run_robot_episodes(ctrl.map_arrays(lambda a: a[rows]), np.array([1 << r for _, r in order]),
                                    seed=11, episode_keys=keys[rows])
    src = np.empty((n, 3), dtype=np.int64)
    for e, (t, r) in enumerate(order):
        src[t, r] = e
    fitness, solved, final = sim.score_teams(played, src)
    assert np.array_equal(fitness, res.fitness)
    assert np.array_equal(solved, res.solved)
    assert np.array_equal(final, own.pose[:, :, :3])


def test_a_robot_shared_by_two_teams_plays_once_for_both():
    """Team 1 is team 0 with robot 0 replaced: its episode needs only that robot's, the rest comes from team 0's."""
    ctrl = teams(2, seed=4)
    for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o"):
        getattr(ctrl, f)[1, 1:] = getattr(ctrl, f)[0, 1:]
    own = BatchSim("plus", 2, TaskParams(**GENERALIZATION))
    res = own.run_controllers(ctrl, seed=2, episode_keys=[5, 5])
    sim = BatchSim("plus", 2, TaskParams(**GENERALIZATION))
    played = sim.run_robot_episodes(ctrl, np.array([0b111, 0b001]), seed=2, episode_keys=[5, 5])
    fitness, solved, _ = sim.score_teams(played, np.array([[0, 0, 0], [1, 0, 0]]))
    assert np.array_equal(fitness, res.fitness) and np.array_equal(solved, res.solved)
    assert res.fitness[0] != res.fitness[1]
    # a robot that did not play stayed at its start
    assert np.array_equal(sim.pose[1, 1:, :3], sim.start_poses(2, np.array([5]))[0, 1:])


def test_robot_episodes_refuse_what_they_cannot_do():
    sim = BatchSim("plus", 2, TaskParams())
    ctrl = teams(2)
    with pytest.raises(ValueError, match="one bit mask per episode"):
        sim.run_robot_episodes(ctrl, np.array([7]))
    played = sim.run_robot_episodes(ctrl, np.array([0b011, 0b100]))
    with pytest.raises(ValueError, match="did not play it"):
        sim.score_teams(played, np.array([[0, 0, 0]]))
    with pytest.raises(ValueError, match="outside"):
        sim.score_teams(played, np.array([[0, 0, 2]]))
    with pytest.raises(ValueError, match=r"shape \(teams, 3\)"):
        sim.score_teams(played, np.array([0, 0, 1]))
    seeing = BatchSim("plus", 2, TaskParams(robots_see_each_other=True))
    with pytest.raises(ValueError, match="do not see each other"):
        seeing.run_robot_episodes(ctrl, np.array([7, 7]))
