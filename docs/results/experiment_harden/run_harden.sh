#!/usr/bin/env bash
# The hardening experiment (issue 15, part 3): the faithful configuration (iros2011-multistep), noise-free until a
# run's first solution and 50 generations more (the solution spreads), then 200 generations in which every team is
# scored on 3 episodes with the generalisation noise (fresh draws each generation, common to the generation) and
# 1 noise-free episode, mean aggregate.
# Resumable: run it again to continue. Usage: bash run_harden.sh [OUT]   (default runs/harden)
set -euo pipefail
OUT=${1:-runs/harden}
export NUMBA_NUM_THREADS=1  # two workers on two cores
mahn-evo experiment --modes situational --runs 15 --seed 1 --preset iros2011-multistep \
  --noise generalization --episodes 3 --noise-draws per_generation --noise-free-episode --aggregate mean \
  --robust-from first_solution --robust-delay 50 --after-solved 250 --out "$OUT" --workers 2 --no-analysis
mahn-evo experiment --out "$OUT" --report-only
