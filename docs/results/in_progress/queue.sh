#!/usr/bin/env bash
# The project's long experiments in priority order, in two lanes of one core each, every step resumable: a session
# starts this, stops it before it ends (`kill -TERM -- -$(cat RUNS_DIR/queue.pid)`: SIGTERM, since a script's
# background jobs ignore SIGINT; runs keep their last finished generation), and parks what it ran (park.py park).
# Parked experiments are restored first, run by run (a run further along here is kept). A finished experiment's
# report is made once (its results.json).
#
#   mkdir -p RUNS_DIR && setsid nohup bash docs/results/in_progress/queue.sh RUNS_DIR >> RUNS_DIR/queue.out 2>&1 < /dev/null &
#
# Runs use the installed mahn, or PYTHONPATH (e.g. a worktree pinned at a commit, so that editing the checkout
# does not change runs in progress). A step that fails goes on to the lane's next step; a stopped one (SIGTERM,
# Ctrl-C) ends the lane.
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
RUNS=${1:-runs}
if [ -d "${PYTHONPATH:-}" ]; then export PYTHONPATH=$(cd "$PYTHONPATH" && pwd); fi  # absolute, before the cd below
mkdir -p "$RUNS" && cd "$RUNS"
echo $$ > queue.pid  # the process group to stop: this script leads it (started with setsid)
for name in robot15; do
  [ -d "$HERE/$name" ] && python "$HERE/park.py" restore "$name" "$name"
done
[ -d "$HERE/fair" ] && python "$HERE/park.py" restore-lean fair fair  # issue 12's lean PPO runs (park-lean)
for m in ppo_ff ippo_gru mappo_gru; do  # issue 12's tuning journals (docs/results/baselines/fair_runs/README.md)
  kept="$HERE/../baselines/fair_runs/tune_$m/study.jsonl"
  if [ -f "$kept" ] && [ ! -f "fair/tune_$m/study.jsonl" ]; then mkdir -p "fair/tune_$m" && cp "$kept" "fair/tune_$m/"; fi
done
# one core per lane: a run left to itself takes every core for its compiled loops, and two such runs on two cores
# would share them four threads to two
export NUMBA_NUM_THREADS=1

step() {  # run one step; 1 (end the lane) only when it was stopped
  "$@"
  local rc=$?
  if [ $rc -eq 130 ] || [ $rc -eq 143 ]; then return 1; fi
  [ $rc -ne 0 ] && echo "$(date -u) step failed ($rc), going on: $*"
  return 0
}

final_rl() {  # issue 12's final runs of one method on seeds 0-4 (docs/baselines.md), once its tuning has finished
  local m=$1 steps=$2
  if [ ! -f "fair/tune_$m/best.json" ]; then echo "$(date -u) no fair/tune_$m/best.json yet: $m's final runs wait"; return 0; fi
  for s in 0 1 2 3 4; do
    step python -m baselines lean --method "$m" --steps "$steps" --seed $s --out "fair/${m}_seed$s" --resume \
        --hyperparams "$(cat "fair/tune_$m/best.json")" --threads 1 || return
  done
}

lane_a() {
  # issue 12: the recurrent IPPO's tuning and final runs (the other methods run in lane B)
  step python -m baselines tune --method ippo_gru --trials 25 --steps 2e7 --out fair/tune_ippo_gru --threads 1 || return
  final_rl ippo_gru 1e8 || return
  # issue 15: experiment_robot's seeds not yet on its page
  step python -m mahn_evo.cli experiment --out robot15 --modes situational --runs 15 --seed 1 \
      --preset hardened-sequential --noise robot --generations 1000 --after-solved 300 --workers 1 --no-analysis \
      --only-seeds 6 7 9 10 12 13 14 15 || return
  # and each of its finished runs checked (the page's pilot_check.py; kept in the experiment folder, so parked)
  mkdir -p robot15/checks
  for run in robot15/runs/situational_s*; do
    name=$(basename "$run")
    [ -f "$run/summary.json" ] && [ ! -s "robot15/checks/$name.jsonl" ] || continue
    step python "$HERE/../robot_pilot/pilot_check.py" "$HERE/../experiment_hardened_sequential" "$run" \
        > "robot15/checks/$name.jsonl.tmp" && mv "robot15/checks/$name.jsonl.tmp" "robot15/checks/$name.jsonl" || return
  done
}

lane_b() {
  # issue 12: tuning, then the final runs (docs/baselines.md, "What remains to run"); ippo_gru runs in lane A
  for m in ppo_ff mappo_gru; do
    step python -m baselines tune --method $m --trials 25 --steps 2e7 --out fair/tune_$m --threads 1 || return
  done
  final_rl ppo_ff 2e8 || return
  final_rl mappo_gru 1e8 || return
}

lane_a > lane_a.out 2>&1 &
lane_b > lane_b.out 2>&1 &
wait
