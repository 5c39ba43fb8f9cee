"""MuJoCo contact impedance per pair role (:mod:`sim.backends.roles`; measured in
docs/simulation.md, "MuJoCo: contact roles", "MuJoCo: the sliding lift-off" and "MuJoCo: sliding
supports"): which ``solimp``/``solref`` each pair of a built model gets and the model-wide
``impratio``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sim.backends.mujoco_squeeze import contact_diag_a, load_width
from sim.backends.roles import CARRY, SQUEEZE, SUPPORT


def apply_role_impedance(m: Any, d: Any, roles: Mapping[str, str],
                         subpairs: Mapping[str, list[int]], load: float, opts: Any
                         ) -> dict[str, float]:
    """Set the impedance of every model pair of ``m`` (``subpairs``: scene pair -> model pair
    indices) by its scene pair's role, and ``m.opt.impratio``; return the load width given to
    each soft ``squeeze`` pair (:func:`sim.backends.mujoco_squeeze.load_width`).

    ``opts`` carries the backend's options (:class:`sim.backends.mujoco_engine.MujocoBackend`):
    ``squeeze`` pairs get ``solimp = (squeeze_d0, solimp[0], load width)`` and
    ``squeeze_solref`` when ``squeeze_d0`` is set; ``support`` pairs ``support_solimp`` and
    ``support_solref`` (each when set); ``carry`` pairs ``carry_solref``. ``impratio``:
    ``carry_impratio`` in a scene with ``carry`` pairs and no ``squeeze`` pair, else
    ``support_impratio`` (when set) in a scene with ``support`` pairs, else unchanged.
    ``load`` [N] is the scene's (:func:`sim.backends.mujoco_squeeze.scene_load`)."""
    widths: dict[str, float] = {}
    for name, role in roles.items():
        # one load width per scene pair, from its touching contacts (the finger's MuJoCo
        # pairs with the workpiece's other edge boxes get the same impedance); only a soft
        # squeeze pair needs it
        soft = role == SQUEEZE and opts.squeeze_d0 is not None and load > 0
        diag_a = max((contact_diag_a(m, d, i) for i in subpairs[name]), default=0.0) \
            if soft else 0.0
        soft = soft and diag_a > 0
        for i in subpairs[name]:
            if role == SUPPORT:
                if opts.support_solimp is not None:
                    m.pair_solimp[i] = opts.support_solimp
                if opts.support_solref is not None:
                    m.pair_solref[i] = opts.support_solref
            elif role == CARRY and opts.carry_solref is not None:
                m.pair_solref[i] = opts.carry_solref
            elif soft:
                # soft (squeeze_d0) at zero penetration, the stiff default's impedance at zero
                # (solimp[0]) from the load width on; the width at the default stiffness,
                # which squeeze_solref keeps
                tc = max(float(m.pair_solref[i][0]), 2.0 * float(m.opt.timestep))
                d_far = float(m.pair_solimp[i][0])
                w = load_width(load, opts.squeeze_d0, d_far, (tc, float(m.pair_solref[i][1])),
                               diag_a)
                m.pair_solimp[i] = (opts.squeeze_d0, d_far, w, float(m.pair_solimp[i][3]),
                                    float(m.pair_solimp[i][4]))
                if opts.squeeze_solref is not None:
                    m.pair_solref[i] = opts.squeeze_solref
                widths[name] = w
    kinds = set(roles.values())
    if CARRY in kinds and SQUEEZE not in kinds:
        m.opt.impratio = opts.carry_impratio
    elif SUPPORT in kinds and opts.support_impratio is not None:
        m.opt.impratio = opts.support_impratio
    return widths
