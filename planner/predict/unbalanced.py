"""Which way an undriven workpiece without static equilibrium starts to move.

When every commanded joint velocity is zero and no mode is feasible, no set of contact forces
inside the friction cones balances the load ``g_obj`` (eqs. 2, 21-22, 26): the workpiece
accelerates, which the quasistatic model does not describe.  What it can say is which part of the
load is left over: the *unbalanced load*

    r = g_obj + W_E lambda*,   lambda* = argmin_{lambda >= 0} |S (g_obj + W_E lambda)|,

where the columns of ``W_E`` are the wrenches of the friction-cone edges of every contact,
``w_in + mu_i w_it`` and ``w_in - mu_i w_it`` (eq. 1; a frictionless contact's two coincide),
and ``S`` scales each body's moment row by ``1 / L`` (``L`` the workpiece size, so forces and
moments weigh alike).  ``r`` is the force and moment (about the world origin, per body) that the
contacts cannot take; the workpiece starts to move along it.  (Non-negative least squares,
:func:`scipy.optimize.nnls`.)
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import nnls

from planner.model.system import System


def length_scale(system: System) -> float:
    """``L`` [m]: the workpiece polygon's size, else the contacts' largest distance from the
    origin (1 when every contact is at the origin)."""
    wps = system.workpieces or ((system.workpiece,) if system.workpiece is not None else ())
    if wps:
        return max(float(np.ptp(np.asarray(w.polygon), axis=0).max()) for w in wps)
    r = float(np.max(np.linalg.norm(system.points, axis=1))) if system.n_contacts else 0.0
    return r if r > 0 else 1.0


def unbalanced_load(system: System, mu: np.ndarray) -> np.ndarray:
    """``r (3 n_b,)`` [N, N, N m]: the part of ``g_obj`` no contact force within the friction
    cones balances (module docstring); zero when a static equilibrium exists."""
    W, g = system.W, system.g_obj
    mu = np.asarray(mu, dtype=float)
    cols = []
    for i in range(system.n_contacts):
        wn, wt = W[:, 2 * i], W[:, 2 * i + 1]
        cols += [wn + mu[i] * wt, wn - mu[i] * wt]
    E = np.stack(cols, axis=1)
    s = np.tile([1.0, 1.0, 1.0 / length_scale(system)], system.n_bodies)
    lam, _ = nnls(s[:, None] * E, -s * g)
    return g + E @ lam


def describe_motion(system: System, r: np.ndarray) -> str:
    """Plain words for an unbalanced load ``r``: per body, the direction of its force and its
    sense of turning about the body's centre of mass (or the origin when no geometry)."""
    wps = system.workpieces or ((system.workpiece,) if system.workpiece is not None else ())
    parts = []
    for a in range(system.n_bodies):
        f, m = r[3 * a:3 * a + 2], float(r[3 * a + 2])
        about = "the origin"
        if len(wps) > a:
            c = np.asarray(wps[a].com)
            m -= float(c[0] * f[1] - c[1] * f[0])
            about = "its centre of mass"
        size = float(np.hypot(*f))
        scale = max(size, abs(m) / length_scale(system), 1e-300)
        words = []
        if size > 1e-9 * scale:
            angle = math.degrees(math.atan2(f[1], f[0]))
            words.append(f"pushed {_direction(angle)} by {size:.3g} N (towards {angle:.0f} deg)")
        if abs(m) > 1e-9 * scale * length_scale(system):
            sense = "counter-clockwise" if m > 0 else "clockwise"
            words.append(f"turned {sense} by {abs(m):.3g} N m about {about}")
        who = "the workpiece" if system.n_bodies == 1 else f"workpiece {a}"
        if words:
            parts.append(f"{who} is {' and '.join(words)}")
    return "; ".join(parts) if parts else "no unbalanced load"


def _direction(angle: float) -> str:
    names = ("right", "up and right", "up", "up and left", "left", "down and left", "down",
             "down and right")
    return names[int(round(angle / 45.0)) % 8]
