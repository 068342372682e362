"""queue.sh's final_pool: the two lanes share issue 12's final runs, each run taken once, in order, only after its
method's tuning has finished; a lane waits for a tuning running in the other lane, not for one nobody runs (its
functions run in bash with `python -m baselines lean` replaced by a stand-in that records the call and finishes the
run)."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
QUEUE = ROOT / "docs" / "results" / "in_progress" / "queue.sh"

# `python -m baselines lean ...` records its method, seed and lane and writes the summary of a finished run; any
# other python call is the real one
STAND_IN = f"""#!/usr/bin/env bash
if [ "$1 $2 $3" = "-m baselines lean" ]; then
  shift 3
  while [ $# -gt 0 ]; do
    case "$1" in --method) m=$2;; --seed) s=$2;; --out) out=$2;; --steps) steps=$2;; esac; shift
  done
  mkdir -p "$out"
  echo "{{\\"steps\\": $(python3 -c "print(int(float('$steps')))")}}" > "$out/summary.json"
  echo "$m $s $LANE" >> calls.log
  sleep 0.05
  exit 0
fi
exec {sys.executable} "$@"
"""


def _functions() -> str:
    """queue.sh's step() and the final runs' functions, without the lanes and the restore steps around them."""
    text = QUEUE.read_text()
    return text[text.index("step() {"):text.index("lane_a() {")]


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_the_lanes_share_the_final_runs_each_once_after_its_tuning(tmp_path):
    shim = tmp_path / "bin"
    shim.mkdir()
    (shim / "python").write_text(STAND_IN)
    (shim / "python").chmod(0o755)
    runs = tmp_path / "runs"
    for method, done in (("ppo_ff", 25), ("ippo_gru", 12), ("mappo_gru", 3)):  # two tunings still running
        (runs / "fair" / f"tune_{method}").mkdir(parents=True)
        (runs / "fair" / f"tune_{method}" / "tuning_cost.json").write_text(
            json.dumps({"trials_completed": done - 2, "trials_pruned": 2}))
        (runs / "fair" / f"tune_{method}" / "best.json").write_text('{"hidden": 8}')
    for seed in (1, 3):  # runs finished in an earlier session are not run again
        (runs / "fair" / f"ppo_ff_seed{seed}").mkdir()
        (runs / "fair" / f"ppo_ff_seed{seed}" / "summary.json").write_text(json.dumps({"steps": 200_000_000}))
    # nor one only kept in the repository (archived to fair_runs/, its parked copy removed): queue.sh looks there
    # from its own folder, HERE (docs/results/in_progress)
    kept = tmp_path / "docs" / "results" / "baselines" / "fair_runs" / "ppo_ff_seed4"
    kept.mkdir(parents=True)
    (kept / "summary.json").write_text(json.dumps({"steps": 200_082_432}))
    (tmp_path / "docs" / "results" / "in_progress").mkdir()
    shutil.copy2(QUEUE.parent / "park.py", tmp_path / "docs" / "results" / "in_progress")  # finished() asks it
    (runs / "fair" / "ippo_gru_seed0").mkdir()  # one that stopped short of its budget is resumed
    (runs / "fair" / "ippo_gru_seed0" / "summary.json").write_text(json.dumps({"steps": 5_000_000}))
    finish = """echo '{"trials_completed": 23, "trials_pruned": 2}' > fair/tune_ippo_gru/tuning_cost.json"""
    script = f"HERE={tmp_path / 'docs' / 'results' / 'in_progress'}\n" + _functions() + f"""
rm -rf fair/.claims && mkdir -p fair/.claims
touch fair/.claims/tuning_ippo_gru fair/.claims/tuning_mappo_gru  # both tunings running, as `tune` marks them
# IPPO's tuning ends while the lanes wait; MAPPO's stops unfinished (a crash): nobody will tune it this session
(sleep 3; {finish}; rm fair/.claims/tuning_ippo_gru; sleep 1; rm fair/.claims/tuning_mappo_gru) &
(LANE=a final_pool) & (LANE=b final_pool) & wait
"""
    env = dict(os.environ, PATH=f"{shim}:{os.environ['PATH']}", POOL_WAIT="0.1")
    subprocess.run(["bash", "-c", script], cwd=runs, env=env, check=True, timeout=120)
    calls = [line.split() for line in (runs / "calls.log").read_text().splitlines()]
    taken = [(m, int(s)) for m, s, _ in calls]
    assert taken[:2] in ([("ppo_ff", 0), ("ppo_ff", 2)], [("ppo_ff", 2), ("ppo_ff", 0)])  # only these were ready
    assert sorted(taken[2:]) == [("ippo_gru", s) for s in range(5)]  # then IPPO's, once its tuning ended;
    # MAPPO's wait for a tuning nobody runs any more: the lanes return (to their next work) without them
    assert {lane for _, _, lane in calls} == {"a", "b"}  # both lanes worked, each run taken once


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_the_queue_refuses_to_start_without_the_rl_extra(tmp_path):
    """Where `import optuna, torch` fails (a new machine without the rl extra), queue.sh exits 2 saying what to
    install, before it creates the runs folder or restores anything: otherwise every RL step fails and each lane
    goes on to the next (stop 55)."""
    shim = tmp_path / "bin"
    shim.mkdir()
    (shim / "python").write_text("#!/usr/bin/env bash\n"
                                 "[ \"$1\" = \"-c\" ] && case \"$2\" in *optuna*) exit 1;; esac\n"
                                 f"exec {sys.executable} \"$@\"\n")
    (shim / "python").chmod(0o755)
    runs = tmp_path / "runs"
    env = {**os.environ, "PATH": f"{shim}{os.pathsep}{os.environ['PATH']}"}
    done = subprocess.run(["bash", str(QUEUE), str(runs)], env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "pip install -e '.[rl]'" in done.stderr and "not started" in done.stderr
    assert not runs.exists()
