"""Band curves of a segment with one effort-controlled joint, for Figures 10-13 (Section 5.2).

Per waypoint and per kinematically admissible mode: its effort interval at the friction
interval's two ends (eq. 28 at ``mu_lo`` and ``mu_hi``: Figures 10-12), and over the interval
the set where it is guaranteed and the hull where it is possible (Figure 13).  Stored in a
segment's ``extra["curves"]`` (docs/plan-format.md) and drawn by
:func:`planner.plots.bounds.plot_bounds`.  Efforts in the joint's units (N m or N).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from planner.model.hand import Hand
from planner.plan.bounds import mode_bands
from planner.plan.intervals import EMPTY, Interval
from planner.plan.partition import Guaranteed, joint_inputs
from planner.plan.trajectory import Trajectory

#: Per waypoint, every mode's ``{label: (family, interval)}`` at one friction value.
BandsAt = list[dict[str, tuple[str, Interval]]]


def bands_at_ends(hand: Hand, states: Trajectory, V: tuple[int, ...], mu_lo: np.ndarray,
                  mu_hi: np.ndarray) -> tuple[BandsAt, BandsAt]:
    """Per waypoint of ``states``, every mode's interval at the friction interval's two ends:
    ``(at_lo, at_hi)`` (one effort-controlled joint; the joints ``V`` at the trajectory's
    rates)."""
    at_lo: BandsAt = []
    at_hi: BandsAt = []
    for k in range(len(states.t)):
        system = hand.system(states.q[k], 0.0, joint_inputs(hand, V, states.thetadot[k, list(V)]))
        for mu_v, out in ((mu_lo, at_lo), (mu_hi, at_hi)):
            bands = mode_bands(system, np.stack([mu_v, mu_v], 1))
            out.append({b.label: (b.mode.family, b.possible) for b in bands})
    return at_lo, at_hi


def band_curves(states: Trajectory, gs: Sequence[Guaranteed], at_lo: BandsAt, at_hi: BandsAt,
                mu_lo: np.ndarray, mu_hi: np.ndarray) -> dict[str, Any]:
    """Band curves for Figures 10-13 (module docstring): ``t``, ``travel`` (m), ``mu_lo``,
    ``mu_hi`` and per mode label ``family``, ``at_lo``, ``at_hi``, ``guaranteed``,
    ``possible`` (each a list of ``[lower, upper]``; None = empty; None inside a pair =
    unbounded)."""
    def enc(iv: Interval) -> list[float | None] | None:
        return None if iv.empty else iv.to_list()

    n = len(states.t)
    modes: dict[str, dict[str, Any]] = {}
    for k in range(n):
        g = gs[k].guarantee
        for b in (g.bands if g is not None else ()):
            m = modes.setdefault(b.label, {"family": b.mode.family, "at_lo": [None] * n,
                                           "at_hi": [None] * n, "guaranteed": [None] * n,
                                           "possible": [None] * n})
            m["at_lo"][k] = enc(at_lo[k].get(b.label, ("", EMPTY))[1])
            m["at_hi"][k] = enc(at_hi[k].get(b.label, ("", EMPTY))[1])
            m["guaranteed"][k] = enc(b.guaranteed)
            m["possible"][k] = enc(b.possible)
    travel = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(states.q[:, :2], axis=0),
                                                              axis=1))])
    return {"t": [float(x) for x in states.t], "travel": [float(x) for x in travel],
            "mu_lo": [float(x) for x in mu_lo], "mu_hi": [float(x) for x in mu_hi],
            "modes": modes}
