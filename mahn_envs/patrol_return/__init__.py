from .env import PatrolReturnEnv, env, parallel_env, raw_env

__all__ = ["PatrolReturnEnv", "env", "parallel_env", "raw_env"]
