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
