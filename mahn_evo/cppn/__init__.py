"""CPPN activation: the original's activation functions and a compiled, vectorised evaluator.

Usage::

    from mahn_evo.cppn import compile_cppn
    plan = compile_cppn(genome, evaluate_modules=False)   # once per genome
    out = plan.evaluate(queries)                           # (Q, n_inputs) -> (Q, n_outputs), float32
"""

from .activations import ACTIVATIONS, activation_code
from .plan import MODE_PRODUCT, MODE_SUM, CppnPlan, compile_cppn

__all__ = ["ACTIVATIONS", "activation_code", "CppnPlan", "compile_cppn", "MODE_SUM", "MODE_PRODUCT"]
