"""Draw the built-in maps: walls, home, POIs, start poses, and the asymmetric plus's numbers.

    python examples/plot_maps.py                  # writes runs/examples/maps.png
    python examples/plot_maps.py docs/maps.png    # regenerates the README's figure
"""
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from mahn_envs import load_map  # noqa: E402
from mahn_evo.plots import draw_world  # noqa: E402

out = Path(sys.argv[1] if len(sys.argv) > 1 else "runs/examples/maps.png")
out.parent.mkdir(parents=True, exist_ok=True)
fig, axes = plt.subplots(1, 2, figsize=(10, 5.6), dpi=110)
for ax, name in zip(axes, ["plus", "asymmetric_plus"]):
    w = load_map(name)
    draw_world(ax, w)
    for x, y, h in w.starts:
        ax.plot(x, y, "o", color="C0", ms=5)
        ax.arrow(x, y, 6 * np.cos(h), 6 * np.sin(h), head_width=2, color="C0")
    ax.set_title(f"{name} (cm, y up)")
    xmin, ymin, xmax, ymax = w.bounds
    ax.set_xlim(xmin - 10, xmax + 10)
    ax.set_ylim(ymin - 10, ymax + 10)
ax = axes[1]
ax.annotate("left arm 48.43", (54.5, 112), fontsize=7, ha="center")
ax.annotate("centre arm 118.11\n(1.5 x 78.74)", (60, 170), fontsize=7, ha="right")
ax.annotate("right arm 118.11, centre line\n77.5 above the junction's", (167, 194), fontsize=7, ha="center")
fig.tight_layout()
fig.savefig(out)
print("wrote", out)
