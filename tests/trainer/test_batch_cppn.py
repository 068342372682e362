"""A population's CPPNs evaluated wave by wave: bit-identical to evaluating each plan on its own."""
import numpy as np
import pytest

from mahn_evo.cppn import CppnPlan, compile_cppn
from mahn_evo.cppn import batch as batch_cppn
from mahn_evo.cppn.batch import evaluate_plans
from mahn_evo.hyperneat.substrate import query_layout
from mahn_evo.neat.population import Population
from mahn_evo.neat.settings import NeatSettings


def _evolved_genomes(kind: str, n_inputs: int) -> list:
    """Genomes after a few generations of structural mutation (added nodes, connections, loops)."""
    settings = NeatSettings().replace(population_size=60, add_node_probability=0.3, add_connection_probability=0.4)
    pop = Population.create(settings, seed=2, kind=kind, n_inputs=n_inputs)
    rng = np.random.default_rng(0)
    for _ in range(5):
        pop.tell(rng.uniform(0, 10, len(pop.ask())))
    return pop.ask()


@pytest.mark.parametrize("mode,kind,modules", [("situational", "iros2011", True), ("situational", "iros2011", False),
                                               ("standard", "minimal", False)])
def test_population_evaluation_is_bit_identical_to_plan_by_plan(mode, kind, modules, monkeypatch):
    monkeypatch.setattr(batch_cppn, "BLOCK", 16)  # several blocks, the last one partial
    layout = query_layout(mode)
    plans = [compile_cppn(g, evaluate_modules=modules) for g in _evolved_genomes(kind, layout.n_cppn_inputs)]
    assert len({p.op_act.size for p in plans}) > 2  # genomes of different sizes share the waves
    together = evaluate_plans(plans, layout.queries)
    apart = np.stack([p.evaluate(layout.queries) for p in plans])
    assert together.dtype == np.float32 and together.shape == apart.shape
    assert np.array_equal(together.view(np.uint32), apart.view(np.uint32))


def test_other_plan_kinds_are_evaluated_by_their_own_method():
    layout = query_layout("situational")
    plans = [compile_cppn(g, evaluate_modules=True) for g in _evolved_genomes("iros2011", 6)[:5]]
    calls = []

    class Recorded(CppnPlan):
        def evaluate(self, inputs, dtype=np.float32):
            calls.append(1)
            return super().evaluate(inputs, dtype) + np.float32(1.0)

    plans[2] = Recorded(**{f: getattr(plans[2], f) for f in CppnPlan.__dataclass_fields__})
    out = evaluate_plans(plans, layout.queries)
    assert len(calls) == 1
    assert np.array_equal(out[2], plans[2].evaluate(layout.queries))
