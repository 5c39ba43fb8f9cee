"""Figures 10-13 of Section 5.2 from a plan's band curves (matplotlib, Agg, imported lazily).

* Figure 10 -- the claimed mode's torque bounds at the lower friction end (``mu = 0``);
* Figure 11 -- the same at the upper friction end (``mu = 0.2``);
* Figure 12 -- the rival modes' bounds at the upper end (e.g. the ``R2S`` mode);
* Figure 13 -- the bounds that guarantee the claimed mode for every friction in the interval
  and exclude every rival, with the planned torque commands.

Upper bounds are solid, lower bounds dashed (as in the paper); unbounded ends are clipped to the
plot range and marked with an arrow.  Abscissa: workpiece travel (mm).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from planner.files.atomic import save_figure
from planner.plan.model import Segment


def _series(rows: list[Any], sign: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper curves; with ``sign = -1`` the torque axis is flipped (bounds swap)."""
    lo = np.array([np.nan if r is None else (-np.inf if r[0] is None else r[0]) for r in rows])
    hi = np.array([np.nan if r is None else (np.inf if r[1] is None else r[1]) for r in rows])
    return (lo, hi) if sign > 0 else (-hi, -lo)


def _limits(plan: Segment, sign: float) -> tuple[float, float]:
    """Plot range from the claimed mode's curves and the commands (rivals are clipped)."""
    vals = [sign * w.torque_commands[0] for w in plan.waypoints] + [0.0]
    m = plan.extra["curves"]["modes"].get(plan.claim)
    if m is not None:
        for key in ("at_lo", "at_hi", "guaranteed"):
            for r in m[key]:
                if r is not None:
                    vals += [sign * x for x in r if x is not None]
    v = np.array(vals, dtype=float)
    lo, hi = float(np.min(v)), float(np.max(v))
    pad = 0.35 * max(hi - lo, 1e-9)
    return lo - pad, hi + pad


def _draw(ax, x, lo, hi, colour, label, ylim):
    y0, y1 = ylim
    lo_c = np.clip(lo, y0, y1)
    hi_c = np.clip(hi, y0, y1)
    ok = ~np.isnan(lo) & ~np.isnan(hi) & (lo <= hi)
    ax.fill_between(x, lo_c, hi_c, where=ok, color=colour, alpha=0.18, linewidth=0)
    ax.plot(np.where(ok, x, np.nan), np.where(ok, hi_c, np.nan), "-", color=colour, lw=2.2,
            label=f"{label} upper")
    ax.plot(np.where(ok, x, np.nan), np.where(ok, lo_c, np.nan), "--", color=colour, lw=2.2,
            label=f"{label} lower")
    for arr, y in ((hi, y1), (lo, y0)):
        inf = ok & ~np.isfinite(arr)
        if np.any(inf):
            ax.plot(x[inf], np.full(int(inf.sum()), y), "^" if y == y1 else "v", color=colour,
                    ms=4, ls="none")


def plot_bounds(plan: Segment, out_dir: str | Path) -> list[Path]:
    """Write ``fig10_bounds_mu_lo.png`` ... ``fig13_guaranteed.png`` into ``out_dir`` from a
    segment with one effort-controlled joint and its band curves (``extra["curves"]``,
    :func:`planner.plan.curves.band_curves`).  Raises :class:`planner.errors.InputError`
    for a segment without them."""
    from planner.errors import InputError

    if len(plan.effort_joints) != 1 or "curves" not in plan.extra:
        raise InputError("figures 10-13: expected a segment with one effort-controlled joint "
                         f"and its band curves, got {len(plan.effort_joints)} effort joints"
                         + ("" if "curves" in plan.extra else " and no curves"))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    curves = plan.extra["curves"]
    x = 1e3 * np.asarray(curves["travel"])
    modes = curves["modes"]
    claim = plan.claim
    # Show squeezing torques as positive numbers (as the paper does) when the commands are < 0.
    torques = plan.torques()[:, 0]
    sign = -1.0 if float(np.median(torques)) < 0 else 1.0
    ylim = _limits(plan, sign)
    mu_lo = curves["mu_lo"][0]
    mu_hi = curves["mu_hi"][0]
    name = plan.hand_model.hand.joint_names()[plan.effort_joints[0]]
    ylabel = (f"torque of the {name} joint (N m, CCW +)" if sign > 0 else
              f"squeezing torque of the {name} joint, -tau (N m)")
    colours = ["tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange", "tab:brown"]
    rivals = [lab for lab in modes if lab != claim
              and any(r is not None for r in modes[lab]["at_hi"])]
    paths = []

    def new(title):
        fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=110)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("workpiece travel (mm)")
        ax.set_ylabel(ylabel)
        ax.set_ylim(*ylim)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.grid(alpha=0.3)
        return fig, ax

    def finish(fig, ax, fname):
        ax.legend(fontsize=7, loc="best")
        fig.tight_layout()
        paths.append(save_figure(fig, out / fname))
        plt.close(fig)

    fam = modes[claim]["family"] if claim in modes else claim
    for fname, key, mu in (("fig10_bounds_mu_lo.png", "at_lo", mu_lo),
                           ("fig11_bounds_mu_hi.png", "at_hi", mu_hi)):
        fig, ax = new(f"{fam} torque bounds, mu = {mu:g} ({claim})")
        if claim in modes:
            _draw(ax, x, *_series(modes[claim][key], sign), colours[0], fam, ylim)
        finish(fig, ax, fname)
    fig, ax = new(f"rival modes' torque bounds, mu = {mu_hi:g}")
    for i, lab in enumerate(rivals):
        _draw(ax, x, *_series(modes[lab]["at_hi"], sign), colours[(i + 1) % len(colours)],
              f"{modes[lab]['family']} {lab}", ylim)
    if claim in modes:
        lo, hi = _series(modes[claim]["at_hi"], sign)
        ax.plot(x, np.clip(lo, *ylim), ":", color=colours[0], lw=1, label=f"{fam} lower")
        ax.plot(x, np.clip(hi, *ylim), ":", color=colours[0], lw=1, label=f"{fam} upper")
    finish(fig, ax, "fig12_rival_bounds_mu_hi.png")
    fig, ax = new(f"{fam} guaranteed, rivals excluded, mu in [{mu_lo:g}, {mu_hi:g}]")
    band = sign * np.array([w.bands[0] for w in plan.waypoints], dtype=float)
    if sign < 0:
        band = band[:, ::-1]
    _draw(ax, x, band[:, 0], band[:, 1], colours[0], f"guaranteed {fam}", ylim)
    for i, lab in enumerate(rivals):
        lo, hi = _series(modes[lab]["possible"], sign)
        ok = ~np.isnan(lo) & (lo <= hi)
        ax.fill_between(x, np.clip(lo, *ylim), np.clip(hi, *ylim), where=ok, hatch="//",
                        facecolor="none", edgecolor=colours[(i + 1) % len(colours)], lw=0,
                        label=f"{lab} possible")
    ax.plot(x, sign * torques, "k.-", lw=1, ms=3, label=f"command ({plan.policy})")
    finish(fig, ax, "fig13_guaranteed.png")
    return paths


def margin_summary(plan: Segment) -> dict[str, float]:
    """Smallest margin of the commands (N m) and relative to the command's magnitude."""
    m = plan.margins()
    t = np.linalg.norm(plan.torques(), axis=1)
    rel = m / np.where(t > 0, t, math.inf)
    return {"min_margin": float(np.min(m)), "min_relative_margin": float(np.min(rel))}


def slice_polygon(A: np.ndarray, b: np.ndarray, centre: np.ndarray, axes: tuple[int, int]
                  ) -> np.ndarray:
    """Vertices ``(m, 2)`` (counter-clockwise) of the slice of ``{x : A x <= b}`` through
    ``centre`` in the coordinates ``axes`` (the others held at the centre); empty when the slice
    is empty.  Half-space intersection (scipy) from the slice's Chebyshev centre."""
    from scipy.spatial import HalfspaceIntersection

    from planner.plan.polytope import chebyshev_centre

    i, j = axes
    others = [k for k in range(A.shape[1]) if k not in axes]
    A2 = A[:, [i, j]]
    b2 = b - (A[:, others] @ centre[others] if others else 0.0)
    keep = np.linalg.norm(A2, axis=1) > 0
    if np.any(~keep & (b2 < 0)):
        return np.zeros((0, 2))
    A2, b2 = A2[keep], b2[keep]
    c, r = chebyshev_centre(A2, b2)
    if not r > 0:
        return np.zeros((0, 2))
    hs = HalfspaceIntersection(np.hstack([A2, -b2[:, None]]), c)
    v = hs.intersections
    ang = np.arctan2(v[:, 1] - c[1], v[:, 0] - c[0])
    return np.asarray(v[np.argsort(ang)])


def plot_regions(plan: Segment, out_dir: str | Path, names: tuple[str, ...] = ()) -> list[Path]:
    """Effort regions of a planned :class:`planner.plan.model.Segment` (its in-memory
    ``regions``) into ``out_dir``: ``regions.png``.  One effort joint: the band and the
    commands against travel (as Fig. 13); several: slices through each drawn waypoint's
    command in the first two effort joints' plane (the others held at the command), every
    other waypoint, shaded by time; none: the margin (smallest normalised Coulomb slack)
    against travel.  ``names``: joint names for the axes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    E = plan.effort_joints

    def nm(j: int) -> str:
        return names[j] if j < len(names) else f"joint {j}"

    if len(plan.regions) != len(plan.waypoints):
        from planner.errors import InputError

        raise InputError("regions: expected a planned segment (its guaranteed regions are kept "
                         "in memory only), got one without them")
    q = np.array([w.q for w in plan.waypoints])
    x = 1e3 * np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q[:, :2], axis=0),
                                                               axis=1))])
    fig, ax = plt.subplots(figsize=(6.4, 4.6), dpi=110)
    title = f"{plan.claim}: guaranteed over the friction set"
    if len(E) == 0:
        ax.plot(x, [w.margin for w in plan.waypoints], "k.-")
        ax.set_xlabel("workpiece travel (mm)")
        ax.set_ylabel("margin (smallest normalised Coulomb slack)")
    elif len(E) == 1:
        lo = [-r.b[1] for r in plan.regions]
        hi = [r.b[0] for r in plan.regions]
        ax.fill_between(x, lo, hi, color="tab:blue", alpha=0.3, label="guaranteed")
        ax.plot(x, [w.torque_commands[0] for w in plan.waypoints], "k.-", label="command")
        ax.set_xlabel("workpiece travel (mm)")
        ax.set_ylabel(f"effort of {nm(E[0])}")
        ax.legend(fontsize=7)
    else:
        cmap = plt.get_cmap("viridis")
        shown = list(zip(plan.waypoints, plan.regions))[::2]
        for n, (w, reg) in enumerate(shown):
            tau = np.array(w.torque_commands)
            poly = slice_polygon(reg.A, reg.b, tau, (0, 1))
            colour = cmap(n / max(1, len(shown) - 1))
            if len(poly):
                ax.fill(poly[:, 0], poly[:, 1], color=colour, alpha=0.25, lw=0.8,
                        ec=colour, label=f"t = {w.t:.2f} s")
            ax.plot(*tau[:2], "o", color=colour, ms=3)
        ax.set_xlabel(f"effort of {nm(E[0])}")
        ax.set_ylabel(f"effort of {nm(E[1])}")
        ax.legend(fontsize=6, loc="best")
        title += " (slices through the commands)"
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path = save_figure(fig, Path(out_dir) / "regions.png")
    plt.close(fig)
    return [path]
