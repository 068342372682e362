"""The task a saved team is scored on outside training: named noise presets, the TaskParams of a preset, and the
PettingZoo env of a TaskParams.

Shared by `mahn-evo eval` (eval_champion.py), the generalisation test, the margins, the experiment's transfer
tests and robust training (training/config.py's `with_noise`), so a preset means the same noise everywhere.
"""
from __future__ import annotations

from typing import Any

from mahn_envs.core import TaskParams

#: Noise of the generalisation test (sensor noise, stochastic turning and locomotion, small start perturbations).
#: Levels are percentages / cm / rad as documented in TaskParams.
#: "robot": the generalisation test's motion noise with a real Khepera III's IR sensors as the emulator models them
#: (TaskParams.sensor_model "khepera" at a real sensor's noise) and the reflex reading them, as a robot's reflex
#: does (TaskParams.reflex_reads_noise; the generalisation test's reflex reads the noise-free rays, as the
#: original's): docs/results/emulator_check/.
NOISE_PRESETS: dict[str, dict[str, float | bool | str]] = {
    "none": {},
    "generalization": {"sensor_noise": 5.0, "effector_noise": 10.0, "heading_noise": 0.005,
                       "start_jitter_xy": 2.0, "start_jitter_heading": 0.1},
}
NOISE_PRESETS["robot"] = {**NOISE_PRESETS["generalization"], "sensor_noise": 100.0, "sensor_model": "khepera",
                          "reflex_reads_noise": True}
#: the presets a team can be tested under (final validation, the report's transfer tests): every one with noise
TEST_NOISES = tuple(name for name in NOISE_PRESETS if name != "none")


def task_env(map: str, params: TaskParams, engine: str = "kinematic", render_mode: str | None = None):
    """The PettingZoo env of `map` with the task settings of `params` (its fitness sampling is the env's own)."""
    from mahn_envs import patrol_return_v0

    return patrol_return_v0.parallel_env(map=map, engine=engine, render_mode=render_mode,
                                         **{k: v for k, v in params.to_dict().items() if k != "sample_period"})


def task_params(noise: str = "none", **overrides: Any) -> TaskParams:
    """The TaskParams of noise preset `noise` with `overrides` (None values are ignored, as unset CLI flags)."""
    if noise not in NOISE_PRESETS:
        raise ValueError(f"unknown noise preset {noise!r}; choose one of {sorted(NOISE_PRESETS)}")
    kw: dict[str, Any] = dict(NOISE_PRESETS[noise])
    kw.update({k: v for k, v in overrides.items() if v is not None})
    return TaskParams(**kw)
