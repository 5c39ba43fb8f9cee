"""MuJoCo contact impedance per pair role (:mod:`sim.backends.roles`; measured in
docs/simulation.md, "MuJoCo: contact roles", "MuJoCo: the sliding lift-off" and "MuJoCo: sliding
supports"): which ``solimp``/``solref`` each pair of a built model gets, the model-wide
``impratio``, and the soft squeeze impedance's load width (the scene's load, MuJoCo's inverse
effective mass of a pair's contacts)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from sim.backends.roles import CARRY, SQUEEZE, SUPPORT


def apply_role_impedance(m: Any, d: Any, roles: Mapping[str, str],
                         subpairs: Mapping[str, list[int]], load: float, opts: Any
                         ) -> dict[str, float]:
    """Set the impedance of every model pair of ``m`` (``subpairs``: scene pair -> model pair
    indices) by its scene pair's role, and ``m.opt.impratio``; return the load width given to
    each soft ``squeeze`` pair (:func:`load_width`).

    ``opts`` carries the backend's options (:class:`sim.backends.mujoco_engine.MujocoBackend`):
    ``squeeze`` pairs get ``solimp = (squeeze_d0, solimp[0], load width)`` and
    ``squeeze_solref`` when ``squeeze_d0`` is set; ``support`` pairs ``support_solimp`` and
    ``support_solref`` (each when set); ``carry`` pairs ``carry_solref``. ``impratio``:
    ``carry_impratio`` in a scene with ``carry`` pairs and no ``squeeze`` pair, else
    ``support_impratio`` (when set) in a scene with ``support`` pairs, else unchanged.
    ``load`` [N] is the scene's (:func:`scene_load`)."""
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


def scene_load(scene: Any) -> float:
    """The load [N] of a :class:`sim.scene.Scene`: the largest in-plane force of its loads (the
    weight or external wrench that keeps the contacts closed; 0 without loads)."""
    return max((float(np.hypot(*ld.force)) for ld in scene.loads), default=0.0)


def load_width(load: float, d0: float, d_width: float, solref: tuple[float, float],
               diag_a: float) -> float:
    """Penetration [m] at which a contact of impedance ``d0`` carries ``load`` [N] at rest: the
    width over which a ``squeeze`` pair's impedance rises from ``d0`` to ``d_width``.

    MuJoCo (``engine_core_constraint.c``): a resting contact carries ``f_n = K imp |pos| /
    R_n`` with ``R_n = (1 - imp) / imp x diagA`` and, for ``solref = (timeconst, dampratio)``,
    ``K = 1 / (d_width timeconst dampratio)^2``; solved for ``|pos|`` at ``imp = d0``. Below it
    the contact is soft (``d0``: a lightly loaded sliding contact keeps enough penetration
    against the cone's lift, :data:`sim.settings.SQUEEZE_D0`), beyond it ``d_width`` (a squeeze
    of many times the load gets the full impedance). ``diag_a`` [1/kg] is MuJoCo's ``efc_diagA``
    of the contact (its inverse effective mass, from the bodies' masses)."""
    timeconst, dampratio = solref
    k = 1.0 / (d_width * timeconst * dampratio) ** 2
    return load * (1.0 - d0) / d0 * diag_a / (k * d0)


def contact_diag_a(model: Any, data: Any, pair: int) -> float:
    """MuJoCo's ``efc_diagA`` (inverse effective mass along the normal) of model pair ``pair``'s
    contacts in ``data``, the largest; 0 when the pair has none."""
    geoms = {int(model.pair_geom1[pair]), int(model.pair_geom2[pair])}
    out = 0.0
    for c in range(data.ncon):
        con = data.contact[c]
        if con.efc_address >= 0 and {int(con.geom[0]), int(con.geom[1])} == geoms:
            out = max(out, float(data.efc_diagA[con.efc_address]))
    return out


def creep_impratio(model: Any, data: Any, subpairs: Mapping[str, list[int]], force: float,
                   speed: float) -> float:
    """The ``impratio`` [-] at which no contact of the built model creeps faster than
    ``speed`` [m/s] while it sticks under its friction coefficient times ``force`` [N] (the
    largest normal force a contact carries), and every contact sliding at least that fast
    carries its full Coulomb force; 0 for a model without contacts.

    MuJoCo's friction rows are soft constraints with no position term: the solver makes a
    row's acceleration ``a = aref - R f`` with ``aref = -b v`` (``b = 2 / (d_width
    timeconst)``, the damping of its ``solref``), so a sticking contact holding friction
    ``f_t`` reaches the steady slip ``|v| = R_t |f_t| / b`` -- a creep proportional to the
    friction force -- and a sliding one at ``|v|`` carries at most ``b |v| / R_t``. With the
    elliptic cone the friction rows' regulariser is the normal row's over the impratio,
    ``R_t = R_n / impratio`` (``R_n = (1 - imp) / imp x diagA`` from the pair's ``solimp``
    and inverse effective mass). Hence ``impratio >= R_n mu force / (b speed)`` for every
    contact, ``mu`` its model pair's sliding friction; ``R_n`` and ``b`` are read from the
    model's constraint rows (``efc_R``, ``efc_KBIP``) after a forward pass (``data`` must hold
    one), and the largest ratio over the contacts of ``subpairs``' model pairs is returned.
    Noslip iterations cut the creep further; this is the bound without them."""
    if not (force >= 0 and speed > 0):
        raise ValueError(f"creep_impratio: expected force >= 0 and speed > 0, got {force}, "
                         f"{speed}")
    mu_of = {frozenset((int(model.pair_geom1[i]), int(model.pair_geom2[i]))):
             float(model.pair_friction[i][0]) for ks in subpairs.values() for i in ks}
    need = 0.0
    for c in range(data.ncon):
        con = data.contact[c]
        a = int(con.efc_address)
        mu = mu_of.get(frozenset((int(con.geom[0]), int(con.geom[1]))))
        if a < 0 or mu is None:
            continue
        r_n, b = float(data.efc_R[a]), float(data.efc_KBIP[a, 1])
        if b > 0:
            need = max(need, r_n * mu * force / (b * speed))
    return need
