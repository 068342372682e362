"""Training: one evolutionary run, from its configuration to the files it leaves in its run folder.

This folder holds the run's validated configuration (`config`: `EvolutionConfig`, `load_config_file`), the named
configurations of the original code and paper (`presets`: `PRESETS`, `apply_preset`), the generation loop with
checkpoints and resume (`trainer`: `Trainer`, `train`) and the champion file a run writes (`champion`:
`Champion`).  It exports `EvolutionConfig`, `Trainer`, `train` and `Champion`.
"""
from .champion import Champion
from .config import EvolutionConfig
from .trainer import Trainer, train

__all__ = ["Champion", "EvolutionConfig", "Trainer", "train"]
