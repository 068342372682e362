"""The protocol ranking's confirmation on fresh seeds (this page's "Next"): both rankings of every run, each run's
pick through the transfer test, and the verdict fixed in advance (at least 4 of the 5 most general by
`--general-rank protocol` pass at least 8 of 10 noisy sequential episodes on both maps).

    python docs/results/experiment_hardened_sequential/confirmation.py collect runs/rob1000_16 > confirmation.json
    python docs/results/experiment_hardened_sequential/confirmation.py table confirmation.json

`collect` needs the experiment's report (`--report-only ... --general-rank protocol`: final validation and
generalisation test of every run) and its picks.jsonl (picks_transfer.py); it ranks the runs as the report does
(mahn_evo.experiment.transfer.most_general, once per ranking, every run listed) and joins each run's transfer test.
`table` prints the README's table and verdict from that file alone, so the page can be checked without the runs.
"""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

RANKINGS = ("protocol", "generalization")  # the rule fixed in advance, and the paper's beside it
TOP = 5
#: the verdict: at least this many of the TOP by the protocol ranking robust
CONFIRMED_AT = 4


def collect(experiment: Path) -> dict[str, Any]:
    from mahn_evo.experiment.plan import ExperimentPlan
    from mahn_evo.experiment.table import load_runs
    from mahn_evo.experiment.transfer import most_general, robust_on_every_map, transfer_tests
    from mahn_evo.training.champion import Champion

    plan = ExperimentPlan.load(experiment)
    runs = [r for r in load_runs(plan, experiment) if r.finished]
    picks = {row["run"]: row for row in map(json.loads, (experiment / "picks.jsonl").read_text().splitlines())}
    out: dict[str, Any] = {"experiment": experiment.name, "seeds": [r.seed for r in runs], "rankings": {}}
    for rank in RANKINGS:
        entries = most_general(replace(plan, general_rank=rank, top=len(runs)), runs, plan.modes[0],
                               log=lambda _m: None)
        out["rankings"][rank] = [
            {"run": e["run"], "seed": e["seed"], "solution": e["solution"], "file": e["file"],
             "general_solved_fraction": e["general_solved_fraction"],
             "validation_successes": e.get("validation_protocol_successes")} for e in entries]
    out["runs"] = {r.name: {"first_solution": r.generations_to_solve, "pick": picks.get(r.name)} for r in runs}
    # the team each ranking's TOP would send to the transfer test: the pick (picks.jsonl), or for a run without one
    # its archived solution, tested here as the report tests it
    for rank in RANKINGS:
        for e in [e for e in out["rankings"][rank] if e["solution"]][:TOP]:
            run = out["runs"][e["run"]]
            if "tested" in run:
                continue
            pick = run["pick"]
            if pick and pick.get("pick") and e["file"].endswith(pick["pick"]):
                run["tested"] = {"file": e["file"], "plus": pick["plus"], "asymmetric_plus": pick["asymmetric_plus"],
                                 "robust": pick["robust"], "from": "picks.jsonl"}
            else:
                result = transfer_tests(Champion.load(experiment / e["file"]), plan)
                run["tested"] = {"file": e["file"], "from": "collect", "robust": robust_on_every_map(result),
                                 **{m: result[m]["sequential_noisy"]["success_fraction"]
                                    for m in ("plus", "asymmetric_plus")}}
    return out


def _robust(data: dict[str, Any], run: str) -> bool:
    return bool(data["runs"][run]["tested"]["robust"])


def verdict(data: dict[str, Any]) -> dict[str, Any]:
    """The TOP of each ranking (solutions only) and how many of them are robust; confirmed or not."""
    out: dict[str, Any] = {}
    for rank in RANKINGS:
        top = [e["run"] for e in data["rankings"][rank] if e["solution"]][:TOP]
        out[rank] = {"top": top, "robust": sum(_robust(data, r) for r in top)}
    out["confirmed"] = out["protocol"]["robust"] >= CONFIRMED_AT
    return out


def table(data: dict[str, Any]) -> str:
    v = verdict(data)
    general = {e["run"]: e for e in data["rankings"]["generalization"]}
    lines = ["| rank (protocol) | seed | generations to the first solution | validation successes: `plus` of 10 + "
             "variants of 20 | generalisation (25 noisy training episodes) | rank (paper) | noisy sequential "
             "successes `plus` / `asymmetric_plus` |", "|---|---|---|---|---|---|---|"]
    paper_order = [e["run"] for e in data["rankings"]["generalization"]]
    for i, e in enumerate(data["rankings"]["protocol"], 1):
        run = data["runs"][e["run"]]
        pick, first = run["pick"], run["first_solution"]
        tested = run.get("tested") or (pick if pick and pick.get("pick") else None)  # every pick was tested
        if tested is None:
            transfer = ""
        else:
            mark = "**" if tested["robust"] else ""
            transfer = f"{mark}{round(10 * tested['plus'])} / {round(10 * tested['asymmetric_plus'])}{mark}"
        if pick and pick.get("pick"):
            validation = (f"{pick['validation_plus']} + {pick['validation_variants']} = "
                          f"{pick['validation_plus'] + pick['validation_variants']}")
        else:
            validation = "no pick" + (" (its archived solution tested)" if e["solution"] else "")
        lines.append(f"| {i} | {e['seed']} | {'not solved' if first is None else first} | {validation} | "
                     f"{general[e['run']]['general_solved_fraction']:.2f} | {paper_order.index(e['run']) + 1} | "
                     f"{transfer} |")
    seeds = {rank: ", ".join(str(int(r.rsplit("_s", 1)[1])) for r in v[rank]["top"]) for rank in RANKINGS}
    lines += ["", f"- Ranked by the protocol (the rule fixed in advance): seeds {seeds['protocol']}, **"
              f"{v['protocol']['robust']} of {len(v['protocol']['top'])} robust**: "
              + ("confirmed (at least 4)." if v["confirmed"] else "not confirmed (at least 4 needed)."),
              f"- Ranked by the paper's generalisation test: seeds {seeds['generalization']}, "
              f"{v['generalization']['robust']} of {len(v['generalization']['top'])} robust."]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    if len(argv) == 2 and argv[0] == "collect":
        print(json.dumps(collect(Path(argv[1])), indent=1))
        return 0
    if len(argv) == 2 and argv[0] == "table":
        print(table(json.loads(Path(argv[1]).read_text())))
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
