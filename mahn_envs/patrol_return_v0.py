"""PettingZoo-style module: `patrol_return_v0.parallel_env(**kw)` and `patrol_return_v0.env(**kw)` (AEC)."""
from .patrol_return.env import PatrolReturnEnv, env, parallel_env, raw_env

__all__ = ["PatrolReturnEnv", "env", "parallel_env", "raw_env"]
