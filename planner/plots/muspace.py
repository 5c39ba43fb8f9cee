"""Slice maps of friction space (Trinkle & Zeng 1994, Figures 3, 6 and 8); matplotlib is
imported lazily with the Agg backend.

Each panel is one 2-D slice: the fill is the labelled grid of the general test (one colour and
legend entry per mode set, named by what happens: ``jams`` dark grey, ``slips`` (undriven, no
static equilibrium) red, ``stays`` (undriven, at rest), ``moves``, ``ambiguous``); region
boundaries of 3S / RS modes are drawn from the closed-form inequalities (eqs. 35-36, 40-41):
the zero contour of ``min_k sign(D) P_k`` per mode, evaluated on a fine grid (``boundary_n``
per axis) of the exact polynomials, not from pixel edges.  Modes without a closed form
(compliant systems) get dashed boundaries from the grid.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from planner.errors import InputError
from planner.files.atomic import save_figure
from planner.friction.closed_form import ClosedFormRegion
from planner.friction.muspace import MuGrid
from planner.friction.regions import JAM, SLIPS, region_words

if TYPE_CHECKING:
    from matplotlib.artist import Artist

_LINESTYLES = ("-", "--", "-.", ":")
_LINECOLOURS = ("black", "#b2182b", "#2166ac", "#1b7837", "#762a83", "#e08214")


def _signed_margin(region: ClosedFormRegion, mu: np.ndarray) -> np.ndarray:
    """``min_k sign(D) P_k`` (zero on the region boundary, >= 0 inside; eqs. 35-36, 40-41)."""
    return np.min(region.signed_inequalities(mu), axis=1)


def plot_slices(
    grids: Sequence[MuGrid],
    titles: Sequence[str],
    path: str | Path,
    *,
    closed_forms: Sequence[ClosedFormRegion] = (),
    panel_closed_forms: Sequence[Sequence[ClosedFormRegion]] | None = None,
    boundary_n: int = 600,
    decorate: Callable[[Any, int], None] | None = None,
) -> Path:
    """Draw one panel per 2-D grid (one slice of the third coefficient) and save a PNG.

    Parameters
    ----------
    grids : 2-D :class:`MuGrid` panels.
    titles : one title per panel.
    closed_forms : regions whose boundaries are drawn as curves (modes feasible somewhere in
        the panels; others are skipped), shared by all panels.
    panel_closed_forms : one sequence of regions per panel, for panels of different systems
        (e.g. the rod of Fig. 8 at several support positions); overrides ``closed_forms``.
    boundary_n : points per axis of the fine grid on which the exact polynomials are contoured.
    decorate : optional ``decorate(ax, panel_index)`` hook (e.g. Fig. 8's rectangle).
    """
    if not grids or len(titles) != len(grids):
        raise InputError(f"plot_slices: expected one title per grid (>= 1 grid), got "
                         f"{len(grids)} grids and {len(titles)} titles")
    for g in grids:
        if len(g.vary) != 2:
            raise InputError(f"plot_slices: expected 2-D grids, got a {len(g.vary)}-D grid")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    sets = [g.mode_sets() for g in grids]
    names = sorted({s for m in sets for s in m.ravel()}, key=lambda s: (s in (JAM, SLIPS), s))
    driven = all(g.driven for g in grids)
    cmap = plt.get_cmap("tab10" if len(names) <= 10 else "tab20")
    colour: dict[str, Any] = {}
    k = 0
    for s in names:
        if s == JAM:
            colour[s] = (0.25, 0.25, 0.25, 1.0)
        elif s == SLIPS:
            colour[s] = (0.85, 0.55, 0.55, 1.0)
        else:
            colour[s] = cmap(k % cmap.N)
            k += 1
    shown = sorted({lab for g in grids for lab in g.labels})
    if panel_closed_forms is None:
        panel_closed_forms = [closed_forms] * len(grids)
    if len(panel_closed_forms) != len(grids):
        raise InputError(f"plot_slices: expected one closed-form list per panel ({len(grids)}), "
                         f"got {len(panel_closed_forms)}")
    with_closed_form = {r.label for rs in panel_closed_forms for r in rs}
    style = {lab: (_LINECOLOURS[i % len(_LINECOLOURS)], _LINESTYLES[i % len(_LINESTYLES)])
             for i, lab in enumerate(shown)}
    # earlier modes drawn wider so that shared boundary curves stay visible under later ones
    width = {lab: max(1.2, 3.2 - 0.6 * i) for i, lab in enumerate(shown)}
    handles: list[Artist] = [Patch(color=colour[s], label=region_words(s, driven))
                             for s in names]
    handles += [Line2D([], [], color=style[lab][0], linestyle=cast(Any, style[lab][1]), linewidth=2,
                       label=f"boundary of {lab}" + (" (closed form, eqs. 35-36/40-41)"
                                                     if lab in with_closed_form
                                                     else " (grid edges)"))
                for lab in shown]
    ncol = 1 if len(grids) == 1 else 2
    rows = -(-len(handles) // ncol)
    height = 4.0 + 0.22 * rows
    fig, axs = plt.subplots(1, len(grids), figsize=(max(4 * len(grids), 5.5), height),
                            squeeze=False)
    for p, (ax, g, m, title) in enumerate(zip(axs[0], grids, sets, titles)):
        regions = {r.label: r for r in panel_closed_forms[p]}
        img = np.array([[colour[s] for s in row] for row in m.T])
        (x0, x1), (y0, y1) = (g.axes[0][[0, -1]]), (g.axes[1][[0, -1]])
        hx = (x1 - x0) / max(len(g.axes[0]) - 1, 1) / 2
        hy = (y1 - y0) / max(len(g.axes[1]) - 1, 1) / 2
        ax.imshow(img, origin="lower", extent=(x0 - hx, x1 + hx, y0 - hy, y1 + hy),
                  interpolation="nearest", aspect="auto", alpha=0.8)
        fx = np.linspace(x0, x1, boundary_n)
        fy = np.linspace(y0, y1, boundary_n)
        X, Y = np.meshgrid(fx, fy)  # (ny, nx) as contour expects
        mu = np.tile(g.base_mu, (X.size, 1))
        mu[:, list(g.axis_contacts[0])] = X.ravel()[:, None]
        mu[:, list(g.axis_contacts[1])] = Y.ravel()[:, None]
        for lab in shown:  # widest first, so narrower curves stay visible on top
            if lab not in g.labels:
                continue
            j = g.labels.index(lab)
            c, ls = style[lab]
            if lab in regions:
                Z = _signed_margin(regions[lab], mu).reshape(X.shape)
                if np.nanmin(Z) < 0 < np.nanmax(Z):
                    ax.contour(X, Y, Z, levels=[0.0], colors=[c], linestyles=[ls],
                               linewidths=width[lab])
            else:  # no closed form: boundary of the labelled grid (pixel edges)
                F = g.feasible[:, j].reshape(g.shape).T.astype(float)
                if 0 < F.mean() < 1:
                    gx, gy = np.meshgrid(g.axes[0], g.axes[1])
                    ax.contour(gx, gy, F, levels=[0.5], colors=[c], linestyles=["--"],
                               linewidths=1.0)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_xlabel(g.axis_name(0))
        ax.set_ylabel(g.axis_name(1))
        ax.set_title(title)
        if decorate is not None:
            decorate(ax, p)
    fig.legend(handles=handles, loc="lower center", ncol=ncol, fontsize=8)
    fig.tight_layout(rect=(0, (0.22 * rows + 0.15) / height, 1, 1))
    out = save_figure(fig, path, dpi=100)
    plt.close(fig)
    return out
