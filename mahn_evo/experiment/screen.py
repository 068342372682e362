"""A screen: several configurations (one experiment folder each) compared on the same seeds.

Why a separate report: the paper's table compares two modes; a screen compares candidate configurations of one
mode to choose the one that goes to the full experiment.  Only seeds finished in every variant are compared (an
interrupted screen stays paired), each variant's solved count is tested against the baseline variant with Fisher's
exact test, and a survival plot shows the fraction of runs solved by each generation.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..storage.files import atomic_write_json, atomic_write_text
from .plan import ExperimentPlan
from .table import RunRecord, load_runs


def _variant_runs(folder: Path, mode: str, limit: int | None) -> tuple[ExperimentPlan, dict[int, RunRecord]]:
    plan = ExperimentPlan.load(folder)
    runs = [r for r in load_runs(plan, folder) if r.mode == mode]
    if limit is not None:
        runs = [r.at_generation(limit) for r in runs]
    return plan, {r.seed: r for r in runs if r.finished}


def screen_results(folders: Sequence[str | Path], baseline: str, mode: str = "situational",
                   generations: int | None = None) -> dict[str, Any]:
    """Per variant (folder name): solved / runs on the common finished seeds, generations to solve, Fisher's exact
    test against `baseline`, and the survival curve (fraction solved by each generation).

    Variants must have run the same generation limit, or `generations` names a common budget no larger than
    any variant's limit: every run is then read as if it had stopped there (`RunRecord.at_generation`), so a
    300-generation screen can be compared with the first 300 generations of a full experiment."""
    from scipy.stats import fisher_exact

    paths = {Path(f).name: Path(f) for f in folders}
    if len(paths) != len(folders):
        raise ValueError("variant folders must have distinct names (the name is the variant's)")
    variants = {name: _variant_runs(path, mode, generations) for name, path in paths.items()}
    if baseline not in variants:
        raise ValueError(f"baseline {baseline!r} is not one of the variants {sorted(variants)}")
    limits = {plan.generations for plan, _ in variants.values()}
    if generations is None and len(limits) != 1:
        raise ValueError(f"the variants ran different generation limits {sorted(limits)}; a screen compares "
                         "equal budgets (give a common budget no larger than the smallest limit)")
    if generations is not None and not 1 <= generations <= min(limits):
        raise ValueError(f"a common budget of {generations} generations is outside 1..{min(limits)}, the smallest "
                         "limit the variants ran with")
    G = generations if generations is not None else limits.pop()
    common = sorted(set.intersection(*(set(runs) for _, runs in variants.values())))
    base_runs = variants[baseline][1]
    base_solved = sum(base_runs[s].solved for s in common)
    out: dict[str, Any] = {"mode": mode, "generations": G, "baseline": baseline, "seeds": common, "variants": {}}
    for name, (plan, runs) in variants.items():
        rows = [runs[s] for s in common]
        solved = sum(r.solved for r in rows)
        gens = np.array([r.generations_to_solve for r in rows if r.solved], dtype=float)
        entry: dict[str, Any] = {
            "folder": str(paths[name]),
            "finished_seeds": sorted(runs), "runs": len(rows), "solved": int(solved),
            "solved_all_finished": int(sum(r.solved for r in runs.values())),
            "finished_runs": [runs[s].to_dict() for s in sorted(runs)],
            "solved_seeds": [r.seed for r in rows if r.solved],
            "generations_mean": float(gens.mean()) if gens.size else None,
            "generations_median": float(np.median(gens)) if gens.size else None,
            "best_fitness_median": float(np.median([r.best_fitness for r in rows])) if rows else None,
            "survival": [float(np.mean([r.first_solved is not None and r.first_solved <= g for r in rows]))
                         if rows else 0.0 for g in range(G)],
            "plan": {k: v for k, v in plan.to_dict().items()
                     if k in ("init", "evaluate_modules", "cppn_activation", "decision", "neat", "noise", "episodes",
                              "noise_draws", "aggregate", "population")},
        }
        if name != baseline and rows:
            res = fisher_exact([[solved, len(rows) - solved], [base_solved, len(rows) - base_solved]])
            entry["fisher_p_vs_baseline"] = float(res.pvalue)
        out["variants"][name] = entry
    return out


def screen_markdown(res: dict[str, Any]) -> str:
    n = len(res["seeds"])
    lines = [f"# Screen: {res['mode']}, at most {res['generations']} generations",
             "", f"Seeds finished in every variant: {n} ({', '.join(map(str, res['seeds'])) or 'none'}).",
             "", f"| variant | solved by generation {res['generations']} | mean generations to solve | "
                 f"median best fitness | Fisher p vs {res['baseline']} | all its finished seeds |",
             "|---|---|---|---|---|---|"]
    for name, v in res["variants"].items():
        mean = "" if v["generations_mean"] is None else f"{v['generations_mean']:.1f}"
        best = "" if v["best_fitness_median"] is None else f"{v['best_fitness_median']:.1f}"
        p = "" if "fisher_p_vs_baseline" not in v else f"{v['fisher_p_vs_baseline']:.3f}"
        lines.append(f"| {name} | {v['solved']}/{v['runs']} | {mean} | {best} | {p} | "
                     f"{v['solved_all_finished']}/{len(v['finished_seeds'])} |")
    return "\n".join(lines) + "\n"


def survival_plot(res: dict[str, Any], path: str | Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=110)
    g = np.arange(1, res["generations"] + 1)
    for name, v in res["variants"].items():
        ax.step(g, v["survival"], where="post", label=f"{name} ({v['solved']}/{v['runs']})")
    ax.set_xlabel("generation")
    ax.set_ylabel("fraction of runs solved")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title(f"{res['mode']}: runs solved by generation ({len(res['seeds'])} common seeds)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_screen(folders: Sequence[str | Path], baseline: str, out: str | Path,
                 mode: str = "situational", generations: int | None = None) -> dict[str, Any]:
    """screen.json, screen.md and survival.png in `out` (`generations`: see `screen_results`)."""
    res = screen_results(folders, baseline, mode, generations)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "screen.json", res)
    atomic_write_text(out / "screen.md", screen_markdown(res))
    survival_plot(res, out / "survival.png")
    return res
