"""mahn_envs: the IROS 2011 patrol-and-return multirobot task as PettingZoo environments.

`from mahn_envs import patrol_return_v0`; after `import mahn_envs` the env is also registered as
`pettingzoo.make("parallel", "mahn/patrol_return-v0")` (and "aec").
"""
from __future__ import annotations

import pettingzoo as _pz

from . import compile_cache as _compile_cache

_compile_cache.register()  # before any compiled module is imported: kernels are cached on all their sources

from . import patrol_return_v0  # noqa: E402
from .core import BatchSim, TaskParams  # noqa: E402
from .khepera import KheperaModel  # noqa: E402
from .maps import World, load_map  # noqa: E402
from .policies.team_controllers import TeamControllers  # noqa: E402

ENV_ID = "mahn/patrol_return-v0"
if ENV_ID not in _pz.parallel_registry:
    _pz.register("parallel", ENV_ID, entry_point="mahn_envs.patrol_return_v0:parallel_env")
if ENV_ID not in _pz.aec_registry:
    _pz.register("aec", ENV_ID, entry_point="mahn_envs.patrol_return_v0:env")


def __getattr__(name: str):
    if name == "KheperaHardwareEnv":  # optional dependency (pyserial): import on first use
        from .hardware import KheperaHardwareEnv

        return KheperaHardwareEnv
    raise AttributeError(f"module 'mahn_envs' has no attribute {name!r}")


__all__ = ["patrol_return_v0", "TeamControllers", "BatchSim", "TaskParams", "KheperaModel", "World",
           "load_map", "ENV_ID", "KheperaHardwareEnv"]
