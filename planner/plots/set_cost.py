"""What each uncertainty costs, drawn (matplotlib, Agg, imported lazily): one panel per axis of
:func:`planner.plan.set_cost.set_cost` -- mass half-width [kg], centre-of-mass half-width [mm],
friction box width -- with the guaranteed efforts at the plan's binding waypoint against the
axis's size (docs/planning.md, "What each uncertainty costs").

One effort joint: the claim's guaranteed band (light) and the guaranteed pieces -- the band minus
every rival's possible set -- (dark), unbounded ends clipped to the plot range and marked by an
arrow, the planned command as a dotted line; the plan's own size is the dotted vertical line.
Several effort joints: the guaranteed region's radius (its Chebyshev radius; below zero: empty).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from planner.files.atomic import save_figure
from planner.plan.set_cost import AXES, SetCost

#: The file ``qsplan plan --figures`` writes.
COST_FIGURE = "uncertainty_cost.png"

_TITLES = {"mass": "mass half-width [kg]", "com": "centre-of-mass half-width [mm]",
           "friction": "friction box width"}


def _limits(cost: SetCost) -> tuple[float, float]:
    vals = [*cost.command, 0.0]
    for pts in cost.curves.values():
        for p in pts:
            for iv in (p.band, *p.pieces):
                if not iv.empty:
                    vals += [x for x in (iv.lower, iv.upper) if math.isfinite(x)]
    lo, hi = float(min(vals)), float(max(vals))
    pad = 0.25 * max(hi - lo, 1e-9)
    return lo - pad, hi + pad


def plot_set_cost(cost: SetCost, out: str | Path, *, unit: str = "",
                  reference: dict[str, float] | None = None) -> Path:
    """Draw ``cost`` into the PNG ``out``; ``unit`` the efforts' unit, ``reference`` per axis
    the plan's own size (a dotted vertical line; an axis left out has none)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, len(AXES), figsize=(11.0, 3.8), dpi=110, sharey=True)
    one = len(cost.effort_joints) == 1
    ylim = _limits(cost) if one else None
    for ax, axis in zip(axs, AXES):
        pts = cost.curves[axis]
        scale = 1000.0 if axis == "com" else 1.0
        x = np.array([p.size * scale for p in pts])
        if one:
            assert ylim is not None
            y0, y1 = ylim
            span = float(np.max(x) - np.min(x))
            w = 0.35 * (span / (len(x) - 1) if span > 0 and len(x) > 1 else 1.0)
            for k, p in enumerate(pts):
                for iv, alpha in [(p.band, 0.18)] + [(q, 0.55) for q in p.pieces]:
                    if iv.empty:
                        continue
                    lo, hi = max(iv.lower, y0), min(iv.upper, y1)
                    ax.fill_between([x[k] - w, x[k] + w], lo, hi, color="tab:blue",
                                    alpha=alpha, linewidth=0)
                    for end, y, mark in ((iv.upper, y1, "^"), (iv.lower, y0, "v")):
                        if not math.isfinite(end):
                            ax.plot([x[k]], [y], mark, color="tab:blue")
            ax.axhline(cost.command[0], color="k", ls=":", lw=1.2, label="planned command")
            ax.set_ylim(y0, y1)
        else:
            ax.plot(x, [p.radius if math.isfinite(p.radius) else np.nan for p in pts], "o-",
                    color="tab:blue", label="region radius")
            ax.axhline(0.0, color="k", lw=0.8)
        if reference and axis in reference:
            ax.axvline(reference[axis] * scale, color="grey", ls=":", lw=1.0, label="the plan's")
        ax.set_xlabel(_TITLES[axis])
        ax.grid(alpha=0.3)
    axs[0].set_ylabel((f"effort [{unit}]" if one else f"guaranteed radius [{unit}]")
                      if unit else "effort")
    axs[0].legend(fontsize=8, loc="best")
    fig.suptitle(f"What each uncertainty costs: claim {cost.claim}, segment {cost.segment + 1}, "
                 f"t = {cost.t:.3g} s (each axis alone, the others as planned)", fontsize=10)
    fig.tight_layout()
    try:
        return save_figure(fig, out)
    finally:
        plt.close(fig)


def draw_plan_cost(plan: Any, out: str | Path) -> Path:
    """:func:`planner.plan.set_cost.set_cost` of ``plan`` drawn into ``out``."""
    from planner.plan.set_cost import plan_sizes, set_cost
    from planner.plan.wording import effort_unit

    cost = set_cost(plan)
    seg = plan.segments[cost.segment]
    unit = effort_unit(seg.hand_model[0], cost.effort_joints)
    own = {k: v for k, v in plan_sizes(plan).items() if v > 0}
    return plot_set_cost(cost, out, unit=unit, reference=own)
