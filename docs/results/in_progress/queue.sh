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
# on a machine without the rl extra every RL step would fail and each lane go on to the next (stop 55's first start
# on a new host): refuse to start instead, saying what to install
if ! python -c "import optuna, torch" 2> /dev/null; then
  echo "$(date -u) queue.sh: issue 12's steps need the rl extra: pip install torch==2.13.0 && pip install -e '.[rl]'; not started" >&2
  exit 2
fi
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

TRIALS=25  # each method's tuning trials (docs/baselines.md)
FINAL_RUNS="ppo_ff:2e8 ippo_gru:1e8 mappo_gru:1e8"  # issue 12's final runs: method:budget, seeds 0-4 each

tuned() {  # 0 when method $1's study has finished its trials, so its best.json is final (best.json itself is
  # rewritten after every completed trial, so it exists long before)
  python -c "import json, sys
c = json.load(open(f'fair/tune_{sys.argv[1]}/tuning_cost.json'))
sys.exit(0 if c['trials_completed'] + c['trials_pruned'] >= int(sys.argv[2]) else 1)" "$1" "$TRIALS" 2>/dev/null
}

finished() {  # 0 when lean run folder $1 has reached its budget of $2 robot-steps, here or in its kept copy
  python "$HERE/park.py" finished "$1" "$2"
}

tune() {  # method $1's tuning, marked as running (fair/.claims/tuning_$1) while it runs, for final_pool
  local m=$1 rc
  touch "fair/.claims/tuning_$m"
  step python -m baselines tune --method "$m" --trials $TRIALS --steps 2e7 --out "fair/tune_$m" --threads 1
  rc=$?
  rm -f "fair/.claims/tuning_$m"
  return $rc
}

final_pool() {  # issue 12's final runs, shared by both lanes: each lane takes the first run (in FINAL_RUNS order)
  # that is not finished, whose method's tuning has finished, and that the other lane has not claimed (a claim is
  # a directory, made atomically; claims are cleared when the queue starts).  A lane waits while the runs left wait
  # only for a tuning running in the other lane (`tune`), and returns when none is left to take.
  while true; do
    local took=0 waiting=0 job m steps s run
    for job in $FINAL_RUNS; do
      m=${job%%:*}
      steps=${job##*:}
      for s in 0 1 2 3 4; do
        run="fair/${m}_seed$s"
        finished "$run" "$steps" && continue
        if ! tuned "$m"; then
          [ -e "fair/.claims/tuning_$m" ] && waiting=1  # the other lane is tuning it: wait; else nobody will
          continue
        fi
        mkdir "fair/.claims/${m}_seed$s" 2>/dev/null || continue
        took=1
        step python -m baselines lean --method "$m" --steps "$steps" --seed $s --out "$run" --resume \
            --hyperparams "$(cat "fair/tune_$m/best.json")" --threads 1 || return
        break 2
      done
    done
    [ $took -eq 1 ] && continue
    [ $waiting -eq 1 ] || return 0
    sleep "${POOL_WAIT:-120}"  # seconds between looks at the other lane's tuning
  done
}

lane_a() {
  # issue 12: the recurrent IPPO's tuning, then the final runs with lane B (the other tunings run there)
  tune ippo_gru || return
  final_pool || return
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
  # issue 12: the feed-forward and MAPPO tunings (IPPO's runs in lane A), then the final runs with lane A
  tune ppo_ff || return
  tune mappo_gru || return
  final_pool || return
}

rm -rf fair/.claims && mkdir -p fair/.claims  # claims of the final runs (final_pool) are this session's
lane_a > lane_a.out 2>&1 &
lane_b > lane_b.out 2>&1 &
wait
