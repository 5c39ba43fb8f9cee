"""Slice maps of friction space (Trinkle & Zeng 1994, Figures 3 and 6); matplotlib imported lazily.

Differences to the paper's figures: region boundaries are pixel edges of the labelled grid
(closed-form boundary curves, App. A/B, are not drawn yet).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from planner.fileio import save_figure
from planner.muspace import MuGrid


def plot_slices(grids: list[MuGrid], titles: list[str], path: str | Path) -> Path:
    """One panel per 2-D grid (one slice of the third coefficient); one colour per mode set."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    sets = [g.mode_sets() for g in grids]
    names = sorted({s for m in sets for s in m.ravel()}, key=lambda s: (s == "jam", s))
    cmap = plt.get_cmap("tab20")
    colour: dict[str, Any] = {
        s: ((0.15, 0.15, 0.15, 1.0) if s == "jam" else cmap(i % 20)) for i, s in enumerate(names)
    }
    fig, axs = plt.subplots(1, len(grids), figsize=(4 * len(grids), 4.6), squeeze=False)
    for ax, g, m, title in zip(axs[0], grids, sets, titles):
        img = np.array([[colour[s] for s in row] for row in m.T])
        (x0, x1), (y0, y1) = (g.axes[0][[0, -1]]), (g.axes[1][[0, -1]])
        ax.imshow(img, origin="lower", extent=(x0, x1, y0, y1), interpolation="nearest")
        ax.set_xlabel(f"mu_{g.vary[0] + 1}")
        ax.set_ylabel(f"mu_{g.vary[1] + 1}")
        ax.set_title(title)
    fig.legend(handles=[Patch(color=colour[s], label=s) for s in names], loc="lower center",
               ncol=min(3, len(names)), fontsize=8)
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    out = save_figure(fig, path, dpi=100)
    plt.close(fig)
    return out
