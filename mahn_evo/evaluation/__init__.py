"""Evaluation: saved teams scored beyond the episode they were evolved on.

This folder holds the task a saved team is scored on (`task_setup`: noise presets, `task_params`, `task_env`),
`mahn-evo eval` (`eval_champion`: `evaluate_champion` on any map, engine, noise and episodes), the transfer-test
protocols (`protocols`: `sequential`, the paper's real-world protocol in simulation), the paper's generalisation
test (`generalize`) and how firmly a team decides (`margins`: `decision_margins`).  The experiment that runs all
of them over many runs is `mahn_evo.experiment`.  It exports `task_params`, `evaluate_champion`, `sequential`,
`generalize` and `decision_margins`.
"""
from .eval_champion import evaluate_champion
from .generalize import generalize
from .margins import decision_margins
from .protocols import sequential
from .task_setup import task_params

__all__ = ["task_params", "evaluate_champion", "sequential", "generalize", "decision_margins"]
