#!/usr/bin/env bash
# The robust situational experiment: the iros2011-multistep preset, every team scored on 3 noisy episodes
# (generalisation noise, fresh draws each generation, common to the generation) and one noise-free episode,
# mean aggregate. Resumable (rerun to continue).
cd /work/runs/exp_robust
export PYTHONPATH=/work/snap-robust NUMBA_NUM_THREADS=1
python -m mahn_evo.cli experiment --modes situational --runs 15 --seed 1 --preset iros2011-multistep \
  --noise generalization --episodes 3 --noise-draws per_generation --noise-free-episode --aggregate mean \
  --out out --workers 2 --no-analysis >> log.txt 2>&1
