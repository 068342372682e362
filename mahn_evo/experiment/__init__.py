"""The paper's evaluation as one resumable command (`mahn-evo experiment`): plan -> seeded runs (local
processes or Ray) -> table and Fisher's exact test -> most general solutions -> transfer tests -> report."""
from .plan import ExperimentPlan
from .runner import run_experiment

__all__ = ["ExperimentPlan", "run_experiment"]
