"""The pictures a run leaves explain themselves: the fitness curve and the trajectory picture."""
from __future__ import annotations

import csv

import numpy as np

from mahn_envs import load_map
from mahn_evo.plots import fitness_curve, fitness_figure, trajectory_figure, trajectory_plot

ROWS = [{"generation": g, "best_fitness": b, "mean_fitness": m, "best_ever": e}
        for g, b, m, e in [(0, 2.02, 1.5, 2.02), (1, 4.0, 1.7, 4.0), (2, 3.5, 1.8, 4.0), (3, 54.2, 9.0, 54.2),
                           (4, 164.0, 30.0, 164.0)]]


def _close(fig) -> None:
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_fitness_curve_shows_best_so_far_distinctly_on_a_readable_axis():
    fig = fitness_figure(ROWS, "run")
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["mean of each generation", "best of each generation", "best so far (the champion)",
                      "solved: fitness > 100"]
    lines = {line.get_label(): line for line in ax.get_lines()}
    best, per_gen = lines["best so far (the champion)"], lines["best of each generation"]
    # drawn on top, thicker, in its own colour, as a line; each generation's best as dots under it
    assert best.get_zorder() > per_gen.get_zorder() and best.get_linewidth() > 2
    assert best.get_color() != per_gen.get_color() and per_gen.get_linestyle() == "None"
    assert per_gen.get_marker() == "."
    # the y axis names plain fitness values (not powers of ten), including 0, 10 and the solved line's 100
    fig.canvas.draw()
    ticks = [t.get_text() for t in ax.get_yticklabels()]
    assert {"0", "10", "100"} <= set(ticks) and not any("^" in t or "$" in t for t in ticks)
    assert ax.get_ylim()[1] > 164.0  # the best value stays inside the picture
    _close(fig)


def test_fitness_curve_writes_a_png(tmp_path):
    log = tmp_path / "log.csv"
    with open(log, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(ROWS[0]))
        w.writeheader()
        w.writerows(ROWS)
    fitness_curve(log, tmp_path / "fitness.png", "run")
    assert (tmp_path / "fitness.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _paths(n_ticks: int = 50) -> np.ndarray:
    world = load_map("plus")
    starts = np.asarray(world.starts, dtype=float)
    steps = np.linspace(0, 1, n_ticks + 1)[:, None, None]
    return starts[None] + steps * np.array([0.0, -20.0, 0.0])  # (T+1, R, 3)


def test_trajectory_legend_explains_dashed_lines_and_markers(tmp_path):
    world = load_map("plus")
    fig = trajectory_figure(world, _paths(), "team", signal_tick=25)
    legend = fig.axes[0].get_legend()
    entries = {t.get_text(): h for t, h in zip(legend.get_texts(), legend.legend_handles)}
    assert [k for k in entries if k.startswith("robot_")] == ["robot_0", "robot_1", "robot_2"]
    assert entries["before the signal"].get_linestyle() == "-"
    assert entries["after the signal (come home)"].get_linestyle() == "--"
    assert entries["start"].get_marker() == "o" and entries["end"].get_marker() == "s"
    _close(fig)
    # without a signal there are no dashed lines, so the legend does not mention them
    fig = trajectory_figure(world, _paths(), "sequential protocol")
    texts = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "after the signal (come home)" not in texts and "start" in texts and "end" in texts
    _close(fig)
    trajectory_plot(world, _paths(), tmp_path / "paths.png", "team", signal_tick=25)
    assert (tmp_path / "paths.png").stat().st_size > 5000
