"""The experiment's results folder: results.json (everything), results.md (the table a paper needs, beside
the published figures), runs.csv, and figures/ (fitness curves with spread, fraction of runs solved per
generation, and the paths of the transferred teams)."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.maps import load_map

from ..plots import ROBOT_COLOURS, _mpl, draw_world
from ..storage.files import atomic_write_csv, atomic_write_json, atomic_write_text, versioned
from ..training.champion import Champion
from .backends import map_in_processes
from .plan import ExperimentPlan
from .table import PAPER, RunRecord, curves, fisher, load_runs, mode_table
from .transfer import (
    ROBUST_SUCCESS,
    TRANSFER_MAPS,
    most_general,
    replays,
    robust_on_every_map,
    trajectories,
    transfer_tests,
    validate_final_populations,
)

MODE_COLOURS = {"situational": "#0f9d58", "standard": "#4285f4"}


def _transfer_file(path: str, plan: dict[str, Any]) -> dict[str, Any]:
    """transfer_tests of the champion file at `path` (a worker process's job: plain arguments in and out)."""
    return transfer_tests(Champion.load(path), ExperimentPlan.from_mapping(plan))


def write_results(plan: ExperimentPlan, out: str | Path, runs_wall_seconds: float = 0.0,
                  log: Callable[[str], None] = print, workers: int = 1) -> dict[str, Any]:
    """The experiment's results.json, runs.csv, results.md, figures and replays.  The most general solutions'
    transfer tests (minutes each: the sequential protocol's episodes) run on up to `workers` processes."""
    out = Path(out)
    runs = load_runs(plan, out)
    table = mode_table(plan, runs)
    test = fisher(table, plan.modes)
    validate_final_populations(plan, runs, log)
    general: dict[str, list[dict[str, Any]]] = {mode: most_general(plan, runs, mode, log) for mode in plan.modes}
    chosen = [e for mode in plan.modes for e in general[mode]]
    transfers = map_in_processes(_transfer_file, [(str(out / e["file"]), plan.to_dict()) for e in chosen], workers)
    for e, transfer in zip(chosen, transfers):
        e["transfer"] = transfer
    figures = _figures(plan, out, runs, general)
    films = []
    for entries in general.values():
        for e in entries[:plan.replays]:
            films += [str(p.relative_to(out)) for p in replays(Champion.load(out / e["file"]), out / "replays",
                                                               e["run"], seed=plan.seed)]
    results = {"plan": plan.to_dict(), "table": table, "fisher": test, "most_general": general,
               "runs": [r.to_dict() for r in runs], "paper": PAPER, "figures": figures, "replays": films,
               "last_invocation_run_seconds": round(runs_wall_seconds, 1)}
    atomic_write_json(out / "results.json", versioned("experiment_results", results))
    header = list(runs[0].to_dict()) if runs else []
    atomic_write_csv(out / "runs.csv", header, [list(r.to_dict().values()) for r in runs])
    atomic_write_text(out / "results.md", markdown(results))
    log(f"wrote {out / 'results.json'}, {out / 'results.md'} and {len(figures)} figure(s)")
    return results


# ---------------------------------------------------------------------------------------------- markdown
def _fmt(v: Any, digits: int = 1) -> str:
    if v is None:
        return "–"
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


def _ties(entry: dict[str, Any]) -> str:
    m = entry["transfer"].get("margins")  # absent in results written before margins were recorded
    if not m:
        return "n/a"
    flips = f" / {m['flipped']}" if "flipped" in m else ""  # absent in results written before the probe
    return f"{100 * m['tied_fraction']:.0f}% / {100 * m['near_tie_fraction']:.0f}%{flips}"


#: how a plan's fitness_memory (other than the paper's "generation") reads in the report's first line
_MEMORY_TEXT = {
    "lifetime": (", a team's fitness the mean of its scores over every generation it was scored in and the archive "
                 "its leaders (`--fitness-memory lifetime`)"),
    "archive": (", NEAT selecting by each generation's score and the archive keeping the leaders by the mean over "
                "every generation a team was scored in (`--fitness-memory archive`)"),
}


def _robust_text(plan: dict[str, Any]) -> str:
    """How the plan's runs were scored under noise and on which maps, for the report's first line ('' for
    noise-free plans on the map alone)."""
    spread = float(plan.get("map_spread", 0.0))
    branch = float(plan.get("map_branch", 0.0))
    variant = [f"arm lengths x [{1 - spread:g}, {1 + spread:g}] (`--map-spread {spread:g}`)"] if spread else []
    sides = plan.get("branch_sides", "both")
    if branch and sides in ("one", "one_short"):
        shorter = ", shorter by that offset" if sides == "one_short" else ""
        variant += [f"one side arm at the crossing and the other leaving the top arm [29.53, {branch:g}] cm above it"
                    f"{shorter} (`--map-branch {branch:g} --branch-sides {sides}`)"]
    elif branch:
        variant += [f"side arms leaving the top arm [0, {branch:g}] cm above the crossing (`--map-branch {branch:g}`)"]
    plain = int(plan.get("plain_episodes", 0))
    each = f"the first {plain} on the map itself (`--plain-episodes {plain}`), the others" if plain else "each"
    maps = f", {each} on a plus variant with {' and '.join(variant)}" if variant else ""  # '' on the map itself
    if plan.get("noise", "none") == "none":
        return f"; {plan['episodes']} episode(s) per team{maps}" if maps else ""
    text = (f"teams scored on {plan['episodes']} episode(s) with the `{plan['noise']}` noise{maps} "
            f"({plan['noise_draws']} draws, {plan['aggregate']} aggregate"
            f"{', plus one noise-free episode' if plan.get('noise_free_episode') else ''}"
            f"{' on the map itself' if plan.get('noise_free_episode') and maps else ''}"
            + (f", {plan['noise_free_variants']} noise-free episode(s) on plus variants (`--noise-free-variants "
               f"{plan['noise_free_variants']}`)" if plan.get("noise_free_variants") else "")
            + (f", {plan['sequential_episodes']} episode(s) of the sequential protocol (`--sequential-episodes "
               f"{plan['sequential_episodes']}`"
               + (f", the first {plan['sequential_plain']} on the map itself: `--sequential-plain "
                  f"{plan['sequential_plain']}`" if plan.get("sequential_plain") else "")
               + ")" if plan.get("sequential_episodes") else "") + ")")
    text += _MEMORY_TEXT.get(plan.get("fitness_memory", "generation"), "")
    if plan.get("robust_from", "start") == "first_solution":
        clean_branch = float(plan.get("noise_free_branch", 0.0))
        if plan.get("branch_sides", "both") in ("one", "one_short"):
            shape = (f"one side arm at the crossing and the other leaving the top arm [29.53, {clean_branch:g}] cm "
                     f"above it{', shorter by that offset' if plan.get('branch_sides') == 'one_short' else ''}")
        else:
            shape = f"side arms leaving the top arm [0, {clean_branch:g}] cm above the crossing"
        on = (f" (on plus and on a plus variant with {shape}, new each generation: `--noise-free-branch "
              f"{clean_branch:g}`)") if clean_branch else ""
        return (f"; noise-free{on} until a run's first solution and {plan.get('robust_delay', 0)} generation(s) "
                f"more, then {text}")
    return f"; {text}"


def _team_text(plan: dict[str, Any]) -> str:
    """The task settings the teams were evolved with beyond the paper's (TEAM_FIELDS: the reflex variant, the input
    ceiling), for the report's first line ('' for the original's)."""
    text = ""
    if plan.get("reflex_arc"):
        text += "; the arcing reflex (`--reflex-arc`" + (
            ", from the robust phase on: `--reflex-arc-from robust_phase`)"
            if plan.get("reflex_arc_from") == "robust_phase" else ")")
    ceiling = float(plan.get("input_ceiling", 1.0))
    if ceiling < 1.0:
        text += f"; sensor values at or above {ceiling:g} read 1 (`--input-ceiling {ceiling:g}`)"
    return text


def _selection_text(plan: dict[str, Any]) -> str:
    """The team's symmetry and how NEAT selected, for the report's first line ('' for the paper's: robots painted
    at their own z, selection by fitness alone)."""
    text = ""
    if plan.get("symmetry", "none") == "mirror":
        text += "; robot 0 the mirror image of robot 2 (`--symmetry mirror`)"
    elif plan.get("symmetry", "none") == "best":
        text += "; each team scored as painted and in both mirror readings, the best counts (`--symmetry best`)"
    if plan.get("restart_every"):
        text += f"; a fresh population every {plan['restart_every']} generations until the first solution"
    if plan.get("diversity"):
        text += (f"; NEAT selects by fitness + {plan['diversity']:g} x behavioural diversity (robot end positions, "
                 f"{plan.get('diversity_k', 15)} nearest teams)")
    return text


def markdown(results: dict[str, Any]) -> str:
    plan, table, test = results["plan"], results["table"], results["fisher"]
    lines = ["# Experiment results", "",
             f"Modes {', '.join(plan['modes'])}; {plan['runs']} runs per mode (seeds {plan['seed']}–"
             f"{plan['seed'] + plan['runs'] - 1}); population {plan['population']}; at most {plan['generations']} "
             f"generations; init `{plan['init']}`"
             f"{' with Multiply modules evaluated' if plan['evaluate_modules'] else ''}"
             f"; map `{plan['map']}`; episodes of {plan['max_cycles']} ticks{_robust_text(plan)}{_team_text(plan)}"
             f"{_selection_text(plan)}. Written by "
             "`mahn-evo experiment`.", "",
             "## Solved runs", "",
             "| mode | runs finished | in progress | solved | generations to solve: mean | sd | median | range | "
             "paper |", "|---|---|---|---|---|---|---|---|---|"]
    for mode, t in table.items():
        p = PAPER.get(mode, {})
        paper = f"{p['solved']}/{p['runs']}" + (f", {p['generations_mean']} ± {p['generations_sd']}"
                                                 if "generations_mean" in p else "") if p else "–"
        rng = f"{t['generations_min']}–{t['generations_max']}" if t["solved"] else "–"
        lines.append(f"| {mode} | {t['runs_finished']} | {t['runs_in_progress']} | {t['solved']} | "
                     f"{_fmt(t['generations_mean'])} | {_fmt(t['generations_sd'])} | "
                     f"{_fmt(t['generations_median'])} | {rng} | {paper} |")
    lines.append("")
    lines.append("Generations to solve count generations evaluated up to and including the first solution; the sd "
                 "is the sample sd (n − 1).  Mean and sd are over solved runs, as in the paper.")
    for mode, t in table.items():
        if "solved_under_noise" in t:
            lines += ["", f"Robust phase ({mode}): in {t['solved_under_noise']} of the {t['solved']} solved runs a "
                          "generation scored under noise held a team that solved all its episodes."]
    if test:
        lines += ["", f"Fisher's exact test (two-sided), solved vs not solved, {test['modes'][0]} vs "
                      f"{test['modes'][1]}: table {test['table']}, p = {test['p_value']:.3g} "
                      f"(paper: p {PAPER['fisher_p']})."]
    from_final = plan.get("general_from", "archive") == "final_validation"
    by_protocol = plan.get("general_rank", "generalization") == "protocol"
    lines += ["", "## Most general solutions and transfer", "",
              ("Per run, the final validation's pick (below; `--general-from final_validation`; a run without one: "
               "its archived solution with the best score), scored over " if from_final else
               "Per run, the archived solution with the best score over ") +
              f"{plan['general_episodes']} noisy episodes on `{plan['map']}`; the best of those from distinct runs"
              + (" by the pick's successes in the final validation's noisy sequential episodes on the map and its "
                 "plus variants, the generalisation score breaking ties (`--general-rank protocol`; the general "
                 "column's third number)" if by_protocol else "") + ". "
              + (f"Each run's archive also holds the best noise-free solution of its final population on "
                 f"{plan['final_validation']} validation episodes of its own (`mahn-evo final-validation`)"
                 + (f"; of its {plan['final_sequential']} best, the one that succeeds most often in 10 noisy "
                    "episodes of the sequential protocol on the training map"
                    + (f" and {plan['final_family']} on plus variants of its training family (`--final-family "
                       f"{plan['final_family']}`)" if plan.get("final_family") else "")
                    + " (seeds of their own"
                    + (", played in the compiled core: `--final-engine batch`"
                       if plan.get("final_engine", "pymunk") == "batch" else "") + ")"
                    if plan.get("final_sequential") else "") + ". "
                 if plan.get("final_validation") else "") +
              "`training`: all robots called at tick 690 (team fitness, solved). `sequential`: the real-world "
              "protocol in the pymunk engine (robots called home one at a time, sent back out); success = every "
              f"robot reaches its post, returns and goes back out. Noisy columns: {plan['transfer_episodes']} "
              + ("episodes with the generalisation noise. "
                 if plan.get("transfer_noise", "generalization") == "generalization" else
                 "episodes with the robot noise (`--transfer-noise robot`: the generalisation test's motion noise, a "
                 "real Khepera III's IR sensors as the emulator models them, and a reflex that reads them). ")
              + "Ties: the share of the team's decisions on the training "
              "map that are exact ties of the top two outputs / near-ties (< 0.001) / the number of decisions that "
              "input "
              "jitter of +-1e-4 flips; ties are harmless, flips are not (see `mahn-evo eval --margins`).", ""]
    head = "| mode | run | generation | solution | general: solved / mean fitness | ties |"
    sub = "|---|---|---|---|---|---|"
    for m in TRANSFER_MAPS:
        head += f" {m} training | {m} noisy | {m} sequential | {m} seq. noisy |"
        sub += "---|---|---|---|"
    lines += [head, sub]
    for mode, entries in results["most_general"].items():
        for e in entries:
            row = (f"| {mode} | {e['run']} | {e['generation']} | {'yes' if e['solution'] else 'no'} | "
                   f"{e['general_solved_fraction']:.2f} / {e['general_mean_fitness']:.1f}"
                   + (f" / {e['validation_protocol_successes']}" if "validation_protocol_successes" in e else "")
                   + f" | {_ties(e)} |")
            for m in TRANSFER_MAPS:
                t = e["transfer"][m]
                row += (f" {'solved' if t['training']['solved'] else 'not solved'} ({t['training']['fitness']:.1f})"
                        f" | {t['training_noisy']['solved_fraction']:.2f} | "
                        f"{'success' if t['sequential']['success'] else 'fail'} ({t['sequential']['stages']:.2f}) | "
                        f"{t['sequential_noisy']['success_fraction']:.2f} |")
            lines.append(row)
        n_ok = sum(e["transfer"]["transfers"] for e in entries)
        n_robust = sum(robust_on_every_map(e["transfer"]) for e in entries)
        if entries:
            filler = " |" * (5 + 4 * len(TRANSFER_MAPS))
            lines.append(f"| {mode}: **{n_ok}/{len(entries)}** succeed in the sequential protocol on both maps |"
                         + filler)
            lines.append(f"| {mode}: **{n_robust}/{len(entries)}** succeed in at least {ROBUST_SUCCESS:.0%} of the "
                         "noisy sequential episodes on both maps (robust) |" + filler)
    lines += ["", f"Paper: {PAPER['transfer']}.", "", "## Figures", ""]
    for f in results["figures"]:
        lines.append(f"![{Path(f).stem}]({f})")
    if results.get("replays"):
        lines += ["", "## Replays", "", "The most general solution of each mode, exact (no noise):", ""]
        for f in results["replays"]:
            lines.append(f"- [{Path(f).stem}]({f})")
    lines += ["", "## Runs", "", "| run | finished | generations | solved | generations to solve | best fitness | "
              "seconds |", "|---|---|---|---|---|---|---|"]
    for r in results["runs"]:
        lines.append(f"| {r['run']} | {r['finished']} | {r['generations']} | {r['solved']} | "
                     f"{_fmt(r['generations_to_solve'])} | {_fmt(r['best_fitness'], 2)} | {_fmt(r['wall_seconds'])} |")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------- figures
def _figures(plan: ExperimentPlan, out: Path, runs: list[RunRecord], general: dict) -> list[str]:
    plt = _mpl()
    fig_dir = out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    written = []

    fig, ax = plt.subplots(figsize=(6.4, 3.8), dpi=110)
    fig2, ax2 = plt.subplots(figsize=(6.4, 3.4), dpi=110)
    for mode in plan.modes:
        c = curves(plan, runs, mode)
        colour = MODE_COLOURS.get(mode, "#999999")
        n = c["best"].shape[0]
        if n:
            lo, med, hi = np.percentile(c["best"], [25, 50, 75], axis=0)
            ax.plot(c["generation"], med, color=colour, lw=2, label=f"{mode} median (n={n})")
            ax.fill_between(c["generation"], lo, hi, color=colour, alpha=0.25, lw=0)
        ax2.step(c["generation"], c["solved_fraction"], where="post", color=colour, lw=2, label=f"{mode} (n={n})")
    ax.axhline(100, color="#db4437", ls="--", lw=1, label="solved (> 100)")
    ax.set(xlabel="generation", ylabel="best fitness so far", title="best fitness per mode (median, 25–75%)")
    ax.set_yscale("symlog", linthresh=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(fig_dir / "fitness_curves.png")
    ax2.set(xlabel="generation", ylabel="fraction of finished runs solved", ylim=(-0.02, 1.02),
            title="runs solved by generation")
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8, loc="upper left")
    fig2.tight_layout()
    fig2.savefig(fig_dir / "solved_fraction.png")
    plt.close(fig)
    plt.close(fig2)
    written += ["figures/fitness_curves.png", "figures/solved_fraction.png"]

    worlds = {m: load_map(m) for m in TRANSFER_MAPS}
    for mode, entries in general.items():
        if not entries:
            continue
        cols = [f"{m} / {p}" for m in TRANSFER_MAPS for p in ("training", "sequential")]
        fig, axes = plt.subplots(len(entries), len(cols), figsize=(2.6 * len(cols), 2.6 * len(entries)), dpi=100,
                                 squeeze=False)
        for i, e in enumerate(entries):
            paths = trajectories(Champion.load(out / e["file"]), seed=plan.seed)
            for j, key in enumerate(cols):
                ax = axes[i, j]
                draw_world(ax, worlds[key.split(" / ")[0]])
                traj, cut = paths[key]
                cut = len(traj) if cut is None else min(cut + 1, len(traj))
                for r in range(traj.shape[1]):
                    colour = ROBOT_COLOURS[r % len(ROBOT_COLOURS)]
                    ax.plot(traj[:cut, r, 0], traj[:cut, r, 1], color=colour, lw=1)
                    ax.plot(traj[cut - 1:, r, 0], traj[cut - 1:, r, 1], color=colour, lw=0.8, ls="--")
                title = key if i == 0 else ""
                ax.set_title(f"{title}\n{e['run']}" if title else e["run"], fontsize=7)
        fig.tight_layout()
        name = f"figures/transfer_{mode}.png"
        fig.savefig(out / name)
        plt.close(fig)
        written.append(name)
    return written
