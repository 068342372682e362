"""Pictures of runs and teams: fitness curves, trajectories on the map, and episode GIFs."""
from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mahn_envs.maps import World

ROBOT_COLOURS = ["#4285f4", "#db4437", "#0f9d58", "#f4a000", "#ab47bc", "#00acc1"]


def _mpl():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def fitness_curve(log_csv: str | Path, out_png: str | Path, title: str = "") -> None:
    """Best, best-ever and mean fitness per generation; the solved line at 100."""
    with open(log_csv) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return
    plt = _mpl()
    gen = [int(r["generation"]) for r in rows]
    fig, ax = plt.subplots(figsize=(6.4, 3.8), dpi=110)
    ax.plot(gen, [float(r["best_ever"]) for r in rows], label="best so far", color="#0f9d58", lw=2)
    ax.plot(gen, [float(r["best_fitness"]) for r in rows], label="generation best", color="#4285f4", lw=1)
    ax.plot(gen, [float(r["mean_fitness"]) for r in rows], label="generation mean", color="#999999", lw=1)
    ax.axhline(100, color="#db4437", ls="--", lw=1, label="solved (> 100)")
    ax.set_xlabel("generation")
    ax.set_ylabel("team fitness")
    ax.set_yscale("symlog", linthresh=10)
    ax.set_title(title or "fitness")
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out_png)
    plt.close(fig)


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
    """Paths of every robot (trajectories (T+1, R, >=2)); dashed after the signal."""
    plt = _mpl()
    fig, ax = plt.subplots(figsize=(5, 5), dpi=110)
    draw_world(ax, world)
    T = trajectories.shape[0]
    cut = T if signal_tick is None else min(signal_tick + 1, T)
    for r in range(trajectories.shape[1]):
        c = ROBOT_COLOURS[r % len(ROBOT_COLOURS)]
        ax.plot(trajectories[:cut, r, 0], trajectories[:cut, r, 1], color=c, lw=1.5, label=f"robot_{r}")
        ax.plot(trajectories[cut - 1:, r, 0], trajectories[cut - 1:, r, 1], color=c, lw=1.2, ls="--")
        ax.plot(*trajectories[0, r, :2], "o", color=c, ms=4)
        ax.plot(*trajectories[-1, r, :2], "s", color=c, ms=4)
    ax.set_title(title, fontsize=9)
    ax.legend(loc="lower right", fontsize=7)
    fig.tight_layout()
    fig.savefig(out_png)
    plt.close(fig)


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
