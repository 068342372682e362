"""The batch simulation core: the one implementation of the patrol-and-return task."""
from .batch import BatchSim, RunResult, validate_poses
from .params import TaskParams

__all__ = ["BatchSim", "RunResult", "TaskParams", "validate_poses"]
