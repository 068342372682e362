#!/usr/bin/env bash
# Round 2 of the issue-15 screen: NEAT knobs on top of the original code's species order, and the code's rules with
# the MultipleSteps activation.  Situational, population 500, at most 300 generations, stop at the first solution.
# Seeds go round-robin over the variants; rerunning resumes (finished runs kept, running ones continue from their
# checkpoints).  Usage: run_round2.sh OUT_DIR NSEEDS [VARIANT ...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:?usage: run_round2.sh OUT_DIR NSEEDS [VARIANT ...]}
n=${2:?usage: run_round2.sh OUT_DIR NSEEDS [VARIANT ...]}
shift 2
variants=("$@")
[ ${#variants[@]} -gt 0 ] || variants=(code-rules relax-order struct xover-mut sel02 species15 stag50)
for k in $(seq 1 "$n"); do
  for v in "${variants[@]}"; do
    case $v in
      relax-order) flags=(--preset iros2011-multistep);;
      *) flags=(--config "$here/$v.toml");;
    esac
    python -m mahn_evo.cli experiment --modes situational --runs "$k" --seed 1 --generations 300 --after-solved 0 \
      --no-analysis --workers 1 --out "$out/$v" "${flags[@]}"
  done
done
