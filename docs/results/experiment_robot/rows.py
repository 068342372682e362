"""The robot-noise experiment's per-run rows: collected from the run folders and their checks, and printed as the
README's table, so every number on the page comes from runs.jsonl.

  python docs/results/experiment_robot/rows.py collect EXPERIMENT_DIR CHECK_DIR [PUBLISHED] > NEW_RUNS.jsonl
      one JSON line per finished run: its summary.json (seed, first solution, generations, wall time), its
      check (../robot_pilot/pilot_check.py output, CHECK_DIR/situational_sNNN.jsonl, when there is one) and the
      noise-free probes of the checked pick (`mahn-evo probe`, pymunk: which parts of the test map it handles
      without noise, so a failed transfer test reads as geometry or as noise); with PUBLISHED (a runs.jsonl),
      its rows of runs the folder does not hold finished are kept (run folders lost with a machine, the runs
      redone elsewhere: the experiment was split with `mahn-evo experiment --only-seeds`); write to another file
      and move it over PUBLISHED (the shell empties a redirect's target before the script reads it)
  python docs/results/experiment_robot/rows.py table runs.jsonl
      the markdown table and the counts quoted in the README
  python docs/results/experiment_robot/rows.py ranking runs.jsonl CHAMPIONS_DIR
      the five most general picks as the project's selection ranks them (`--general-rank protocol`: the pick's
      noisy sequential successes in its final validation, on plus and on the run's variants, then the paper's
      generalisation test of the pick: 25 noisy training episodes on plus), from the published rows and picks, so
      the experiment's report needs no run folder; and how many of them pass the issue's test
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.evaluation.generalize import keyed_episodes
from mahn_evo.evaluation.probes import probe_team
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.experiment.table import load_runs
from mahn_evo.training.champion import Champion

#: a pick is robust by the issue's test when it succeeds in at least this fraction of the 10 noisy sequential
#: episodes (generalisation noise) on each map
ROBUST = 0.8
#: ... and passes the emulated robots when it solves at least this many of their 10 noisy episodes
EMULATOR_PASS = 8
MAPS = ("plus", "asymmetric_plus")


def collect(experiment_dir: Path, check_dir: Path) -> list[dict]:
    """The runs the experiment counts as finished under its plan (mahn_evo.experiment.table.load_runs: a pilot run
    copied in with a shorter robust phase is not, until its extension ends), each with its summary and check."""
    rows = []
    for record in load_runs(ExperimentPlan.load(experiment_dir), experiment_dir):
        if not record.finished:
            continue
        run = record.name
        summary = json.loads((record.folder / "summary.json").read_text())
        row = {k: summary.get(k) for k in ("seed", "first_solved_generation", "generations", "robust_from_generation",
                                           "wall_seconds")}
        row["run"] = run
        check = check_dir / f"{run}.jsonl"
        if check.exists() and check.read_text().strip():
            row["check"] = json.loads(check.read_text().strip().splitlines()[-1])
            probes = probe_team(Champion.load(record.folder / row["check"]["pick"]))
            row["check"]["run"] = f"{experiment_dir.name}/runs/{run}"  # no machine's paths in published data
            row["probes"] = {"passed": sum(p["success"] for p in probes), "of": len(probes),
                             "failed": [p["name"] for p in probes if not p["success"]]}
        rows.append(row)
    return rows


def read_rows(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def merged(published: list[dict], collected: list[dict]) -> list[dict]:
    """The published rows with the collected ones added, by run; a run collected again replaces its row, keeping
    the published check (and probes) when it was collected without one."""
    by_run = {row["run"]: row for row in published}
    for row in collected:
        old = by_run.get(row["run"], {})
        by_run[row["run"]] = {**{k: old[k] for k in ("check", "probes") if k in old and "check" not in row}, **row}
    return sorted(by_run.values(), key=lambda row: (row["seed"], row["run"]))


def robust(check: dict) -> bool:
    return all(check["transfer"][m] >= ROBUST for m in MAPS)


def emulated(check: dict) -> bool:
    return check["emulator"]["noisy_solved"] >= EMULATOR_PASS


def probed(row: dict) -> str:
    """The noise-free probes the pick passes, and which it fails."""
    p = row.get("probes")
    if p is None:
        return ""
    failed = f" (fails {', '.join(p['failed'])})" if p["failed"] else ""
    return f"{p['passed']}/{p['of']}{failed}"


def table(rows: list[dict]) -> str:
    lines = ["| seed | first solution | generations (robust from) | pick's validation (plus / variants) | "
             "transfer, generalisation noise (plus / asym) | sequential, robot noise (plus / asym) | "
             "core, robot noise | emulator | noise-free probes |",
             "|---|---|---|---|---|---|---|---|---|"]
    for row in sorted(rows, key=lambda r: r["seed"]):
        c = row.get("check")
        first = row["first_solved_generation"]
        gens = f"{row['generations']} ({row['robust_from_generation']})" if row.get("robust_from_generation") \
            else str(row["generations"])
        if c is None:
            lines.append(f"| {row['seed']} | {first if first is not None else 'unsolved'} | {gens} | "
                         "not checked yet | | | | | |")
            continue
        t, s = c["transfer"], c["robot_sequential"]
        mark = "**" if robust(c) and emulated(c) else ""
        lines.append(
            f"| {row['seed']} | {first if first is not None else 'unsolved'} | {gens} | "
            f"{c['validation_plus']}/10, {c['validation_variants']}/20 | "
            f"{mark}{t['plus']:.1f} / {t['asymmetric_plus']:.1f}{mark} | "
            f"{s['plus']:.1f} / {s['asymmetric_plus']:.1f} | "
            f"{c['core']['robot_preset']:.2f} | {mark}{c['emulator']['noisy_solved']}/10{mark} | {probed(row)} |")
    checked = [r["check"] for r in rows if "check" in r]
    solved = [r for r in rows if r["first_solved_generation"] is not None]
    lines += ["", f"{len(rows)} runs finished, {len(solved)} solved; of {len(checked)} checked picks "
              f"{sum(robust(c) for c in checked)} pass the issue's test (>= {ROBUST:.0%} of 10 noisy sequential "
              f"episodes on both maps), {sum(emulated(c) for c in checked)} the emulator (>= {EMULATOR_PASS}/10), "
              f"{sum(robust(c) and emulated(c) for c in checked)} both."]
    return "\n".join(lines)


def ranking(rows: list[dict], champions: Path, top: int = 5, episodes: int = 25, seed: int = 1) -> list[dict]:
    """The checked picks ranked as `mahn_evo.experiment.transfer.most_general` ranks them with general_rank
    "protocol" (its generalisation test: the same keyed episodes for every pick, the plan's seed), best first."""
    entries = []
    for row in rows:
        c = row.get("check")
        if c is None or c.get("pick") is None:
            continue
        champ = Champion.load(champions / f"{row['run']}.json")
        fit, solved = keyed_episodes(TeamControllers.stack([champ.controllers]), "plus",
                                     champ.task(task_params("generalization")), seed, range(episodes))
        entries.append({"seed": row["seed"], "run": row["run"],
                        "protocol": c["validation_plus"] + c["validation_variants"],
                        "general_solved": float(solved.mean()), "general_fitness": float(fit.mean()), "check": c})
    entries.sort(key=lambda e: (-e["protocol"], -e["general_solved"], -e["general_fitness"], e["run"]))
    return entries[:top]


def ranking_table(entries: list[dict], finished: int) -> str:
    lines = ["| rank | seed | validation successes (of 30) | generalisation (solved, mean fitness) | "
             "transfer, generalisation noise (plus / asym) | emulator |", "|---|---|---|---|---|---|"]
    for rank, e in enumerate(entries, 1):
        c = e["check"]
        t = c["transfer"]
        mark = "**" if robust(c) else ""
        lines.append(f"| {rank} | {e['seed']} | {e['protocol']} | {e['general_solved']:.2f}, "
                     f"{e['general_fitness']:.1f} | {mark}{t['plus']:.1f} / {t['asymmetric_plus']:.1f}{mark} | "
                     f"{c['emulator']['noisy_solved']}/10 |")
    lines += ["", f"Of the {len(entries)} most general picks of {finished} finished runs, "
              f"{sum(robust(e['check']) for e in entries)} pass the issue's test (>= {ROBUST:.0%} of 10 noisy "
              f"sequential episodes on both maps; target: 4 of 5), {sum(emulated(e['check']) for e in entries)} "
              f"the emulator."]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    if len(argv) in (3, 4) and argv[0] == "collect":
        rows = collect(Path(argv[1]), Path(argv[2]))
        if len(argv) == 4:
            rows = merged(read_rows(Path(argv[3])), rows)
        for row in rows:
            print(json.dumps(row))
        return 0
    if len(argv) == 3 and argv[0] == "ranking":
        rows = read_rows(Path(argv[1]))
        print(ranking_table(ranking(rows, Path(argv[2])), len(rows)))
        return 0
    if len(argv) == 2 and argv[0] == "table":
        print(table(read_rows(Path(argv[1]))))
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
