"""Pictures of runs and teams: fitness curves, trajectories on the map, and episode GIFs."""
from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mahn_envs.maps import World

if TYPE_CHECKING:
    from matplotlib.figure import Figure

ROBOT_COLOURS = ["#4285f4", "#db4437", "#0f9d58", "#f4a000", "#ab47bc", "#00acc1"]


def _mpl():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


#: Fitness values labelled on the y axis: linear up to 10 (where the patrol credit of early generations lives),
#: logarithmic above (up to the +100 bonus of a solution), with plain numbers rather than powers of ten.
FITNESS_TICKS = (0, 2, 4, 6, 8, 10, 20, 50, 100, 200)


def fitness_curve(log_csv: str | Path, out_png: str | Path, title: str = "") -> None:
    """Best so far (the champion), the best and mean of each generation, and the solved line at 100.

    The best so far is drawn as a thick step line on top, and each generation's best as small dots, because the
    two coincide on most generations and a thin line under a thick one would be invisible.
    """
    with open(log_csv) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return
    fig = fitness_figure(rows, title)
    fig.savefig(out_png, bbox_inches="tight")
    _mpl().close(fig)


def fitness_figure(rows: Sequence[Mapping[str, Any]], title: str = "") -> Figure:
    """The figure of :func:`fitness_curve` from the rows of a run's log.csv (generation, best_fitness,
    mean_fitness, best_ever)."""
    plt = _mpl()
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

    gen = [int(r["generation"]) for r in rows]
    best_ever = [float(r["best_ever"]) for r in rows]
    fig, ax = plt.subplots(figsize=(8.4, 3.8), dpi=110)
    ax.plot(gen, [float(r["mean_fitness"]) for r in rows], label="mean of each generation", color="#999999", lw=1)
    ax.plot(gen, [float(r["best_fitness"]) for r in rows], ".", label="best of each generation", color="#4285f4",
            ms=3)
    ax.step(gen, best_ever, where="post", label="best so far (the champion)", color="#0b6e3a", lw=2.2, zorder=3)
    ax.axhline(100, color="#db4437", ls="--", lw=1, label="solved: fitness > 100")
    ax.annotate(f"{best_ever[-1]:.1f}", (gen[-1], best_ever[-1]), xytext=(4, 0), textcoords="offset points",
                va="center", fontsize=8, color="#0b6e3a")
    ax.set_xlabel("generation")
    ax.set_ylabel("team fitness")
    ax.set_yscale("symlog", linthresh=10, linscale=1.5)
    top = max(150.0, max(best_ever) * 1.3)
    ax.set_ylim(0, top)
    ax.yaxis.set_major_locator(FixedLocator([t for t in FITNESS_TICKS if t <= top]))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_locator(NullLocator())
    ax.set_xlim(gen[0], gen[-1] + max(1, 0.08 * (gen[-1] - gen[0])))
    ax.set_title(title or "fitness")
    # beside the axes: inside, the curves of a short or a long run would each cover some corner
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def draw_world(ax, world: World) -> None:
    for x1, y1, x2, y2 in world.walls:
        ax.plot([x1, x2], [y1, y2], color="#333333", lw=2)
    hx, hy = world.home
    ax.add_patch(_circle(hx, hy, 20, "#999999"))
    ax.text(hx + 3, hy - 6, "home", fontsize=7, color="#666666")
    for p, (px, py) in enumerate(world.pois):
        ax.add_patch(_circle(px, py, 10, "#bbbbbb"))
        ax.text(px + 2, py + 2, f"P{p}", fontsize=7, color="#666666")
    ax.set_aspect("equal")
    ax.axis("off")


def _circle(x, y, r, colour):
    import matplotlib.patches as mpatches

    return mpatches.Circle((x, y), r, fill=False, ls=":", color=colour)


def trajectory_plot(world: World, trajectories: np.ndarray, out_png: str | Path, title: str = "",
                    signal_tick: int | None = None) -> None:
    """Paths of every robot (trajectories (T+1, R, >=2)): solid before the signal, dashed after it; a circle
    marks where a robot started and a square where it ended.  The legend says so, for readers of the picture."""
    fig = trajectory_figure(world, trajectories, title, signal_tick)
    fig.savefig(out_png, bbox_inches="tight")
    _mpl().close(fig)


def trajectory_figure(world: World, trajectories: np.ndarray, title: str = "",
                      signal_tick: int | None = None) -> Figure:
    """The figure of :func:`trajectory_plot`."""
    from matplotlib.lines import Line2D

    plt = _mpl()
    fig, ax = plt.subplots(figsize=(6.2, 5), dpi=110)
    draw_world(ax, world)
    T = trajectories.shape[0]
    cut = T if signal_tick is None else min(signal_tick + 1, T)
    handles = []
    for r in range(trajectories.shape[1]):
        c = ROBOT_COLOURS[r % len(ROBOT_COLOURS)]
        (line,) = ax.plot(trajectories[:cut, r, 0], trajectories[:cut, r, 1], color=c, lw=1.5, label=f"robot_{r}")
        handles.append(line)
        ax.plot(trajectories[cut - 1:, r, 0], trajectories[cut - 1:, r, 1], color=c, lw=1.2, ls="--")
        ax.plot(*trajectories[0, r, :2], "o", color=c, ms=4)
        ax.plot(*trajectories[-1, r, :2], "s", color=c, ms=4)
    key = "#555555"
    if signal_tick is not None:
        handles.append(Line2D([], [], color=key, lw=1.5, label="before the signal"))
        handles.append(Line2D([], [], color=key, lw=1.2, ls="--", label="after the signal (come home)"))
    handles.append(Line2D([], [], color=key, marker="o", ls="", ms=4, label="start"))
    handles.append(Line2D([], [], color=key, marker="s", ls="", ms=4, label="end"))
    ax.set_title(title, fontsize=9)
    # beside the map, not on it: every corner of some map holds an arm, home or a post
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False)
    fig.tight_layout()
    return fig


def save_gif(frames: Sequence[np.ndarray], out_path: str | Path, fps: int = 15, scale: float = 1.0) -> None:
    """Write RGB frames as an animated GIF (Pillow), atomically.

    One shared palette (taken from the first, middle and last frames, so colours that appear late are in it)
    and no dithering: the renderer draws a few flat colours, and quantising every frame on its own is ~10x
    slower for no visible gain.
    """
    from PIL import Image

    if len(frames) == 0:
        raise ValueError("no frames to write")
    sample = np.concatenate([frames[0], frames[len(frames) // 2], frames[-1]], axis=0)
    palette = Image.fromarray(sample).quantize(colors=64, method=Image.Quantize.FASTOCTREE)
    images = [Image.fromarray(f) for f in frames]
    if scale != 1.0:  # smaller files for docs; nearest keeps the palette's flat colours
        size = (max(1, round(images[0].width * scale)), max(1, round(images[0].height * scale)))
        images = [im.resize(size, Image.Resampling.NEAREST) for im in images]
    images = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    tmp = out_path.with_suffix(out_path.suffix + ".tmp")
    images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
    tmp.replace(out_path)
