"""Pairs of contacts that can wedge a workpiece between them: a two-contact force-closure grasp
that the commanded motion squeezes.

Two contacts ``i``, ``j`` on the same workpiece can hold it with equal and opposite forces along
the line between them when that line lies inside both friction cones (``u . n_i >= 1 /
sqrt(1 + mu_i^2)`` and ``-u . n_j >= 1 / sqrt(1 + mu_j^2)``, ``u`` the unit vector from ``r_i``
to ``r_j``: eqs. 21-22 with the force along ``u``); when the commanded contact velocities bring
the two points together along it (``(v_i - v_j) . u > 0``, eq. 5 with the workpiece at rest) such
a squeeze can hold the workpiece with a force that grows with the approach -- a jam that the
rigid quasistatic model's finite-force modes do not list. The simulators' run start depends on
it (:mod:`sim.jobs`: a rigid engine's velocity step wedges such a pair at once, so the drive is
ramped up from rest there), and the validation campaign counts such points apart.
"""

from __future__ import annotations

import numpy as np

from planner.model.system import System

__all__ = ["wedge_pairs"]


def wedge_pairs(system: System, mu: np.ndarray | None = None, turn: float = 0.0,
                slide: np.ndarray | None = None) -> list[tuple[int, int]]:
    """Contact pairs ``(i, j)`` (1-based) of ``system`` that can wedge a workpiece (module
    docstring) at friction ``mu`` (default the system's). ``turn`` [rad] and ``slide`` (n_c,)
    [m] widen each cone's half-angle by how far the line can turn during a run: the workpiece
    turns by up to ``turn`` and the contacts slide along its edges by up to ``slide`` (the line
    turns by ``(slide_i + slide_j) / |r_j - r_i|``)."""
    mu_arr = np.asarray(system.mu if mu is None else mu, dtype=float)
    pts = np.asarray(system.points, dtype=float)
    nrm = np.asarray(system.normals, dtype=float)
    tng = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
    rates = np.zeros(system.n_joints)
    V = system.velocity_joints
    rates[V] = np.asarray(system.joint_inputs, dtype=float)[V]
    vc = (np.asarray(system.J, dtype=float) @ rates).reshape(-1, 2)  # (v_n, v_t) per contact
    v = vc[:, :1] * nrm + vc[:, 1:] * tng
    bodies = [a for a, _ in system.contact_bodies]
    out = []
    for i in range(len(pts)):
        for j in range(i + 1, len(pts)):
            d = pts[j] - pts[i]
            length = float(np.linalg.norm(d))
            if bodies[i] != bodies[j] or not length > 0:
                continue
            u = d / length
            widen = turn + (0.0 if slide is None else float(slide[i] + slide[j]) / length)
            if (u @ nrm[i] >= np.cos(min(np.arctan(mu_arr[i]) + widen, np.pi / 2))
                    and -u @ nrm[j] >= np.cos(min(np.arctan(mu_arr[j]) + widen, np.pi / 2))
                    and (v[i] - v[j]) @ u > 0):
                out.append((i + 1, j + 1))
    return out
