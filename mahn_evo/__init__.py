"""mahn_evo: multiagent HyperNEAT (NEAT -> CPPN -> substrate -> team controllers) for the patrol-and-return task.

One folder per concept: `neat/` (NEAT), `cppn/` (CPPN activation), `hyperneat/` (substrate decoding and the
evaluator), `training/` (configuration, presets, the generation loop, champions), `evaluation/` (saved teams
scored beyond training), `experiment/` (the paper's experiment), `storage/` (the files users keep); `deploy.py`
drives real robots, `plots.py` draws, `cli.py` is `mahn-evo`.  docs/architecture.md maps every module.
"""
from mahn_envs import compile_cache as _compile_cache

_compile_cache.register()  # before the compiled CPPN and substrate modules: cached on all their sources
