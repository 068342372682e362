#!/usr/bin/env bash
# The screen of issue 15: each candidate configuration on situational seeds 1..15 for at most 300 generations
# (population 500, stop at the first solution).  Seeds go round-robin over the variants, so an interrupted screen
# has the same seeds for every variant; rerunning this script resumes (finished runs are kept, interrupted ones
# continue from their checkpoints).  Usage: run_screen.sh OUT_DIR [VARIANT ...]
set -euo pipefail
out=${1:?usage: run_screen.sh OUT_DIR [VARIANT ...]}
shift
variants=("$@")
[ ${#variants[@]} -gt 0 ] || variants=(default iros2011-code iros2011-paper relax random-order)
declare -A flags=(
  [default]=""
  [iros2011-code]="--preset iros2011-code"
  [iros2011-paper]="--preset iros2011-paper"
  [relax]="--cppn-activation relax"
  [random-order]="--config $(dirname "$0")/random_order.toml"
)
for k in $(seq 1 15); do
  for v in "${variants[@]}"; do
    # shellcheck disable=SC2086
    python -m mahn_evo.cli experiment --modes situational --runs "$k" --seed 1 --generations 300 --after-solved 0 \
      --no-analysis --workers 1 --out "$out/$v" ${flags[$v]}
  done
done
