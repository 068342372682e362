"""The batch simulation core: the one implementation of the patrol-and-return task.

`BatchSim` runs episodes; `api` gives the same rules to callers that sense, move or track robots themselves.
"""
from .api import Arena, ScoreKeeper, encode_inputs, policy_coordinates, readings_from_ranges, steer
from .batch import BatchSim, RunResult, validate_poses
from .params import TaskParams

__all__ = ["Arena", "BatchSim", "RunResult", "ScoreKeeper", "TaskParams", "encode_inputs", "policy_coordinates",
           "readings_from_ranges", "steer", "validate_poses"]
