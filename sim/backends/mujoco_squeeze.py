"""The soft squeeze impedance of MuJoCo contact pairs (``sim.backends.soft_squeeze``;
docs/simulation.md, "MuJoCo: the sliding lift-off"): the scene's load, the load width and
MuJoCo's inverse effective mass of a pair's contacts."""

from __future__ import annotations

from typing import Any

import numpy as np


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
    against the cone's lift, :data:`sim.backends.SQUEEZE_D0`), beyond it ``d_width`` (a squeeze
    of many times the load is as stiff as before). ``diag_a`` [1/kg] is MuJoCo's ``efc_diagA``
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
