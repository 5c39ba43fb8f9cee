"""Section 5.1 in friction space (Fig. 8): the rod on two approaching supports with static and
kinetic coefficients.

The rod (contact 1 at ``x = -l1`` moving ``+x``, contact 2 at ``x = +l2`` moving ``-x``, normals
``(0, 1)``, ``g_obj = (0, -1, 0)``) has two feasible modes: ``R1 S-2`` below or on the line
``l1 mu2 = l2 mu1`` and ``S+1 R2`` above or on it (eqs. 40-41).  With a coefficient ``mu_iR``
while contact ``i`` rolls (sticks) and ``mu_iS`` while it slides, the current point of friction
space is a corner of the rectangle ``[mu_1S, mu_1R] x [mu_2S, mu_2R]``: ``(mu_1S, mu_2R)`` in
``S+1 R2`` (upper left), ``(mu_1R, mu_2S)`` in ``R1 S-2`` (lower right).  The sliding contact
approaches the centre of mass, the line rotates, and the mode switches when the line passes the
current corner: in ``S+1 R2`` at ``l1 = l2 mu_1S / mu_2R``, in ``R1 S-2`` at
``l2 = l1 mu_2S / mu_1R`` -- the line "bounces" between the two corners.

The scenario writes ``ruler_muspace.json`` (parameters, the states at the start and at every
switch with their friction-space maps and closed forms) and ``ruler_muspace.png`` (one panel
per state: map, closed-form boundary, the line, the rectangle and the current point), and checks
that the closed-form boundary is the line and that the general test confirms every switch.
Options: ``n`` (grid points per axis, default 120), ``switches`` (default 4).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from planner.files.atomic import atomic_write_json
from planner.friction.muspace import muspace_map
from planner.predict.feasibility import feasible_modes
from scenarios.muspace_maps import rod
from scenarios.registry import Expect, Scenario, register

#: Friction while sticking (R) and sliding (S) at each contact; support distances from the
#: centre of mass [m] (the same numbers as the simulated ruler in scenarios/simulations.py).
MU_R = (0.5, 0.5)
MU_S = (0.3, 0.3)
L1, L2 = 0.04, 0.025
SLIDE_1, SLIDE_2 = "S+1 R2", "R1 S-2"


def switch_sequence(l1: float, l2: float, mu_r: tuple[float, float], mu_s: tuple[float, float],
                    switches: int) -> list[dict[str, Any]]:
    """States of Sec. 5.1: the start and each switch instant, from the line through the corner.

    Returns dicts with ``l1, l2`` [m], the active ``mode`` before the instant's switch (the start
    mode at index 0), the current corner ``mu`` (2,) and the next mode."""
    # before motion both contacts stick: the start mode is the one feasible at (mu_1R, mu_2R)
    mode = SLIDE_1 if l1 * mu_r[1] > l2 * mu_r[0] else SLIDE_2
    states = [{"l1": l1, "l2": l2, "mode": mode, "next": mode,
               "mu": [mu_s[0], mu_r[1]] if mode == SLIDE_1 else [mu_r[0], mu_s[1]]}]
    for _ in range(switches):
        if mode == SLIDE_1:  # contact 1 slides towards the COM until l1 mu_2R = l2 mu_1S
            l1 = l2 * mu_s[0] / mu_r[1]
            corner, nxt = [mu_s[0], mu_r[1]], SLIDE_2
        else:  # contact 2 slides until l1 mu_2S = l2 mu_1R
            l2 = l1 * mu_s[1] / mu_r[0]
            corner, nxt = [mu_r[0], mu_s[1]], SLIDE_1
        states.append({"l1": l1, "l2": l2, "mode": mode, "next": nxt, "mu": corner})
        mode = nxt
    return states


def _general_test_confirms(state: dict[str, Any], mu_r, mu_s, eps: float = 1e-6) -> bool:
    """Just before the switch only the active mode holds at its corner; just after, the next
    mode holds at its own corner (feasible_modes, eqs. 24-28)."""
    l1, l2, mode = state["l1"], state["l2"], state["mode"]
    if mode == SLIDE_1:
        before, after = rod(l1 * (1 + eps), l2), rod(l1 * (1 - eps), l2)
        mu_now, mu_next = [mu_s[0], mu_r[1]], [mu_r[0], mu_s[1]]
    else:
        before, after = rod(l1, l2 * (1 + eps)), rod(l1, l2 * (1 - eps))
        mu_now, mu_next = [mu_r[0], mu_s[1]], [mu_s[0], mu_r[1]]
    return (mode in feasible_modes(before, mu_now).labels
            and mode not in feasible_modes(after, mu_now).labels
            and state["next"] in feasible_modes(after, mu_next).labels)


def run(out_dir: Path, n: int = 120, switches: int = 4, **_: Any) -> dict[str, Any]:
    from planner.plots.muspace import plot_slices

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    states = switch_sequence(L1, L2, MU_R, MU_S, int(switches))
    maps = [muspace_map(rod(s["l1"], s["l2"]), (0, 1), [0.3, 0.3], n=int(n)) for s in states]
    rng = np.random.default_rng(0)
    line_ok = True
    for s, m in zip(states, maps):
        # the closed-form boundaries pass through the line; just above it only S+1 R2 holds,
        # just below only R1 S-2
        m1 = rng.uniform(0.01, 1.0, 200)
        on = np.column_stack([m1, s["l2"] * m1 / s["l1"]])
        up = np.column_stack([np.zeros(200), np.full(200, 1e-6)])
        for r in m.closed_forms:
            line_ok &= bool(np.all(np.abs(np.min(r.signed_inequalities(on), axis=1)) < 1e-9))
        line_ok &= bool(np.all(m.closed_form_mode_sets(on + up) == SLIDE_1))
        line_ok &= bool(np.all(m.closed_form_mode_sets(on - up) == SLIDE_2))
    alternates = all(a["next"] != a["mode"] for a in states[1:])
    confirmed = all(_general_test_confirms(s, MU_R, MU_S) for s in states[1:])
    checks = {
        "closed-form boundary is the line l1 mu2 = l2 mu1": line_ok,
        "mode alternates at every switch": alternates,
        "general test confirms every switch": confirmed,
    }

    def decorate(ax: Any, k: int) -> None:
        from matplotlib.patches import Rectangle

        s = states[k]
        ax.add_patch(Rectangle((MU_S[0], MU_S[1]), MU_R[0] - MU_S[0], MU_R[1] - MU_S[1],
                               fill=False, edgecolor="white", linewidth=1.5, linestyle="-"))
        x = np.linspace(0, 1, 50)
        ax.plot(x, s["l2"] / s["l1"] * x, color="white", linewidth=0.8, linestyle=":")
        ax.plot(*s["mu"], marker="*", markersize=14, color="yellow", markeredgecolor="black")
        ax.text(0.02, 0.96, f"l1={s['l1'] * 1e3:.2f} mm, l2={s['l2'] * 1e3:.2f} mm",
                transform=ax.transAxes, va="top", fontsize=8, color="white")

    titles = ["start: " + states[0]["mode"]] + [
        f"switch {k}: {s['mode']} -> {s['next']}" for k, s in enumerate(states[1:], 1)]
    png = plot_slices([m.grids[0] for m in maps], titles, out_dir / "ruler_muspace.png",
                      panel_closed_forms=[m.closed_forms for m in maps],
                      decorate=decorate)
    data = {
        "parameters": {"l1_m": L1, "l2_m": L2, "mu_rolling": list(MU_R), "mu_sliding": list(MU_S),
                       "rectangle": [[MU_S[0], MU_R[0]], [MU_S[1], MU_R[1]]]},
        "line": "l1 mu2 = l2 mu1 (Sec. 5.1, Fig. 8); S+1 R2 above or on it, R1 S-2 below or on",
        "states": [{**s, "map": m.to_dict()} for s, m in zip(states, maps)],
        "switch_positions_m": [s["l1"] if s["mode"] == SLIDE_1 else s["l2"] for s in states[1:]],
    }
    json_path = atomic_write_json(out_dir / "ruler_muspace.json", data)
    failed = [k for k, ok in checks.items() if not ok]
    summary = {
        "scenario": "ruler_muspace", "engine": None, "expect": "info", "status": "info",
        "passed": not failed, "agreement": None,
        "reason": "all checks hold" if not failed else f"failed: {', '.join(failed)}",
        "checks": checks,
        "modes": [s["mode"] for s in states],
        "switch_positions_m": data["switch_positions_m"],
        "files": {"json": str(json_path), "png": str(png)},
    }
    atomic_write_json(out_dir / "summary.json", summary)
    return summary


register(Scenario(name="ruler_muspace",
                  summary="Fig. 8: rod line l1 mu2 = l2 mu1 bouncing between the corners of the "
                          "static/kinetic rectangle",
                  reference="Sec. 5.1, Figs. 7-8", expect=Expect.INFO, run=run,
                  outputs=("ruler_muspace.json", "ruler_muspace.png", "summary.json")))
