"""Independent re-check of a feasible-mode certificate (no solver code used).

Checks, directly from the system's arrays, equilibrium (eqs. 2-3), the velocity relation (eq. 5)
and the per-contact rolling/sliding/breaking conditions (eqs. 9-11, 16-17), and that commanded
joint velocities and efforts are honoured.
"""

from __future__ import annotations

import numpy as np

from planner.model.system import JointControl

ROLL, SLIDE, BREAK = 2, 1, 0


def check_certificate(system, fm, mu=None, rel=1e-9):
    """Raise AssertionError naming the first violated condition."""
    W, J = system.W, system.J
    c = np.asarray(fm.contact_forces).reshape(-1)
    tau = np.asarray(fm.joint_efforts)
    thd = np.asarray(fm.joint_velocities)
    qdot = np.asarray(fm.qdot)
    mu = np.asarray(system.mu if mu is None else mu, dtype=float)
    f_scale = max(np.max(np.abs(c)), np.max(np.abs(system.g_obj)), 1e-12)
    # eq. (2): W c + g_obj = 0
    res2 = W @ c + system.g_obj
    assert np.max(np.abs(res2)) <= rel * f_scale * 10, f"object equilibrium (2) off by {res2}"
    # eq. (3): J^T c = tau - g_man
    res3 = J.T @ c - (tau - system.g_man)
    t_scale = max(np.max(np.abs(tau)) if tau.size else 0.0, f_scale)
    assert np.max(np.abs(res3), initial=0) <= rel * t_scale * 100, f"manipulator equilibrium (3) {res3}"
    # commanded inputs honoured
    for j, ctl in enumerate(system.control):
        if ctl is JointControl.VELOCITY:
            assert thd[j] == system.joint_inputs[j], f"joint {j} velocity not the command"
        else:
            assert abs(tau[j] - system.joint_inputs[j]) <= rel * t_scale * 100, f"joint {j} effort"
    # eq. (5)
    v = W.T @ qdot - J @ thd
    assert np.allclose(v.reshape(-1, 2), fm.contact_velocities, atol=1e-12 * max(1, np.max(np.abs(v))))
    v_scale = max(np.max(np.abs(J @ thd)), 1e-12)
    vn, vt = v[0::2], v[1::2]
    cn, ct = c[0::2], c[1::2]
    for i, (code, xi) in enumerate(zip(fm.mode.codes, fm.mode.xi)):
        tol_v = 1e-8 * v_scale
        tol_f = 1e-8 * f_scale
        if code == ROLL:
            assert abs(vn[i]) <= tol_v and abs(vt[i]) <= tol_v, f"contact {i+1} rolling but moves"
            assert cn[i] >= -tol_f, f"contact {i+1} tensile"
            assert abs(ct[i]) <= mu[i] * cn[i] + tol_f, f"contact {i+1} outside friction cone"
        elif code == SLIDE:
            assert abs(vn[i]) <= tol_v, f"contact {i+1} sliding but separates"
            assert np.sign(vt[i]) == xi != 0, f"contact {i+1} slides against xi"
            assert cn[i] >= -tol_f, f"contact {i+1} tensile"
            assert abs(ct[i] + mu[i] * xi * cn[i]) <= tol_f, f"contact {i+1} not on cone edge (17)"
        else:
            assert vn[i] > 0, f"contact {i+1} breaking but not separating"
            assert cn[i] == 0 and ct[i] == 0, f"contact {i+1} breaking with force"
