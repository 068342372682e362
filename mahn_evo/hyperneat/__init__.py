"""HyperNEAT's middle: how an evolved CPPN becomes a team of controllers, and how a generation of them is scored.

This folder holds the substrate (`substrate`: node positions, the policy-geometry coordinates z and S, and
`decode_population`, which turns a whole population's CPPN outputs into `TeamControllers` at once) and the
trainer's evaluator (`team_evaluator`: `TeamEvaluator` runs genomes -> CPPNs -> controllers -> fitness in one
batch-core call, configured by one frozen `EvaluationSettings` record, `evaluation_settings`).  NEAT itself is in
`mahn_evo.neat`, the CPPN's activation in `mahn_evo.cppn`, the generation loop in `mahn_evo.training`.  It
exports `MODES`, `query_layout`, `decode_population`, `EvaluationSettings` and `TeamEvaluator`.
"""
from .evaluation_settings import EvaluationSettings
from .substrate import MODES, decode_population, query_layout
from .team_evaluator import TeamEvaluator

__all__ = ["MODES", "decode_population", "query_layout", "EvaluationSettings", "TeamEvaluator"]
