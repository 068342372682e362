"""CPPN activation: the original's activation functions and a compiled, vectorised evaluator.

Usage::

    from mahn_evo.cppn import compile_cppn
    plan = compile_cppn(genome, evaluate_modules=False)   # once per genome
    out = plan.evaluate(queries)                           # (Q, n_inputs) -> (Q, n_outputs), float32

`batch.evaluate_plans` evaluates a whole population's plans together, bit-identical to one by one (the
substrate decodes a generation through it).
"""

from .activations import ACTIVATIONS, activation_code
from .plan import MODE_PRODUCT, MODE_SUM, CppnPlan, compile_cppn
from .relax import RelaxPlan, compile_relax

#: How a CPPN is activated for a substrate query: "recursive" (the original's depth-first pass, :mod:`.plan`) or
#: "relax" (the original's commented-out MultipleSteps relaxation, :mod:`.relax`).
CPPN_ACTIVATIONS = ("recursive", "relax")


def compile_genome(genome, activation: str = "recursive", evaluate_modules: bool = False) -> "CppnPlan | RelaxPlan":
    """The evaluation plan of `genome` under the chosen CPPN activation (relaxation always runs the modules)."""
    if activation == "relax":
        return compile_relax(genome)
    if activation != "recursive":
        raise ValueError(f"CPPN activation must be one of {CPPN_ACTIVATIONS}, got {activation!r}")
    return compile_cppn(genome, evaluate_modules=evaluate_modules)

__all__ = ["ACTIVATIONS", "activation_code", "CppnPlan", "compile_cppn", "MODE_SUM", "MODE_PRODUCT", "RelaxPlan",
           "compile_relax", "CPPN_ACTIVATIONS", "compile_genome"]
