"""Training runs pinned to the numbers commit dafc457 produced: speed-ups of the core and the evaluator must leave
every fitness bit-identical, so published runs reproduce from their seeds.

The values below were printed by dafc457's trainer (best and mean team fitness of each generation, exact floats)
for a small population: the paper's seed genome, the minimal one, and noisy multi-episode evaluation.
"""
import pytest

from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer

PINNED = {
    ("iros2011", "none", 1): [(2.075697025660086, 1.652371756987371), (2.075697025660086, 1.6938935052283572),
                              (2.078822000264177, 1.7773681923658398)],
    ("minimal", "none", 1): [(2.4157268911744083, 0.9047747231486711), (2.4157268911744083, 1.3854558390688239),
                             (2.4157268911744083, 1.7392264823152868)],
    ("iros2011", "generalization", 2): [(2.0300132437432814, 1.64050264412793),
                                        (2.0300132437432814, 1.6813124082873023),
                                        (2.0300132437432814, 1.7635868667704997)],
}


@pytest.mark.parametrize("init,noise,episodes", list(PINNED))
def test_training_reproduces_dafc457_exactly(tmp_path, init, noise, episodes):
    cfg = EvolutionConfig(init=init, episodes=episodes, generations=3, seed=5,
                      task=task_params(noise)).with_overrides(pop=40)
    tr = Trainer(cfg, tmp_path)
    got = [(p.best_fitness, p.mean_fitness) for p in (tr.step() for _ in range(3))]
    assert got == PINNED[(init, noise, episodes)]


#: Printed by commit 95d83a3's trainer (the last before robot episodes, TeamEvaluator._play_training): every mirror
#: reading scored (symmetry "best"), noise-free, under the generalisation noise with a noise-free episode, and under
#: the robot's noise on plus and one-sided branch variants; 4 generations of 40 from seed 5.
PINNED_BEST = {
    "noise_free": (dict(init="iros2011", symmetry="best"),
                   [(2.075697025660086, 1.652371756987371), (2.075697025660086, 1.6938935052283572),
                    (2.078822000264177, 1.7773681923658398), (2.2414845361873246, 1.875670802501709)]),
    "generalization": (dict(init="iros2011", symmetry="best", episodes=2, noise_draws="per_generation",
                            noise_free_episode=True, task=task_params("generalization")),
                       [(2.0305129345958512, 1.6444590150810767), (2.2051365395499163, 1.7104764545126039),
                        (2.0946751705431015, 1.722821559331436), (2.1553837214309604, 1.863558531096056)]),
    "robot_branch": (dict(init="minimal", symmetry="best", episodes=2, noise_draws="per_generation", map_branch=49.0,
                          branch_sides="one_short", plain_episodes=1, task=task_params("robot")),
                     [(2.7576994190196555, 1.2165021421300692), (2.9873150216792133, 1.859928778457025),
                      (3.542723019353266, 1.9688692178913576), (3.2315839134695663, 2.076628371177546)]),
    # printed by 51427cb (robot episodes; its runs equal 95d83a3's), before noise-free episodes on the map were
    # remembered across their per-generation keys: the hardened preset's noise-free phase
    "noise_free_branch": (dict(init="iros2011", symmetry="best", episodes=2, noise_draws="per_generation",
                               map_branch=49.0, branch_sides="one_short", plain_episodes=1),
                          [(2.4142948655064496, 1.8396209735508855), (2.4997223051759256, 2.007622636395709),
                           (2.495215234847189, 2.1019252595864693), (2.422529416729982, 2.0867316729919763),
                           (2.4183943314364793, 2.1385994890329463), (2.4839424688394964, 2.289326430078477)]),
}


@pytest.mark.parametrize("case", list(PINNED_BEST))
def test_mirror_readings_played_as_robot_episodes_reproduce_95d83a3_exactly(tmp_path, case):
    settings, pinned = PINNED_BEST[case]
    tr = Trainer(EvolutionConfig(generations=len(pinned), seed=5, **settings).with_overrides(pop=40), tmp_path)
    assert [(p.best_fitness, p.mean_fitness) for p in (tr.step() for _ in range(len(pinned)))] == pinned
