"""The step path's memos (kernels.py: cos and sin of unchanged headings, rays of robots that did not move) kept
across `BatchSim.step` calls: results must be bit-identical to stepping with every memo cleared, through hand
placements, parameter changes and resets."""
import numpy as np

from mahn_envs.core import BatchSim, TaskParams, kernels


def test_step_with_memos_equals_step_without_them():
    params = TaskParams(max_cycles=300, signal_tick=150)
    cached, fresh = BatchSim("plus", 4, params), BatchSim("plus", 4, params)
    rng = np.random.default_rng(3)
    resting = 0
    for episode in range(2):  # the second reset must not reuse the first episode's rays
        for sim in (cached, fresh):
            sim.reset(seed=episode)
        assert np.array_equal(cached.obs, fresh.obs)
        for t in range(params.max_cycles):
            # mostly forward: robots run straight into walls and stand blocked there, where the memos apply
            actions = np.where(rng.random((4, 3)) < 0.85, 1, rng.integers(0, 3, (4, 3)))
            if t == 100:  # a robot placed by hand, as PatrolReturnEnv.place does
                for sim in (cached, fresh):
                    sim.pose[1, 2, :3] = sim.world.starts[2]
                    sim.pose[1, 2, 3] = 0.0
                    sim.resense()
            if t == 200:  # robots that see each other: their rays depend on the others, always cast again
                for sim in (cached, fresh):
                    sim.set_params(robots_see_each_other=True)
            before = cached.pose.copy()
            kernels.forget_rays(fresh._work)
            got = cached.step(actions)
            want = fresh.step(actions)
            for g, w in zip(got, want):
                assert np.array_equal(g, w), (episode, t)
            assert np.array_equal(cached.pose, fresh.pose) and np.array_equal(cached.raw, fresh.raw)
            resting += int(np.sum(np.all(cached.pose[:, :, :3] == before[:, :, :3], axis=-1)))
        cached.set_params(robots_see_each_other=False)
        fresh.set_params(robots_see_each_other=False)
    assert resting > 100  # the memos had robots at rest to skip


def test_reset_senses_every_robot_again():
    """A reset clears the rays before sensing; with the memos kept, robots standing where the last sensing saw
    them would keep cleared rays."""
    sim = BatchSim("plus", 2)
    first = sim.reset(seed=4).copy()
    assert np.array_equal(sim.reset(seed=4), first)
    assert np.any(first[:, :, :6] < 1.0)  # the start poses do see walls
