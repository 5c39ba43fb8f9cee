"""Friction-independent set-up of one system for the kinematic and force stages.

``K = [W^T  -J_E]`` equilibrated for the rank tests (30)-(32) and the solve of eq. (24), and
``G = [W^T  J_E]`` with the right side of eq. (26), built together once per (read-only)
System object (:func:`system_setup`) -- *building* the problem, apart from *solving* it in
:mod:`planner.predict.stages`.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from planner.model.system import System

__all__ = [
    "EquilibratedKinematics", "ForceSetup", "equilibrated_kinematics", "force_rhs",
    "system_setup",
]


@dataclass(frozen=True, eq=False)
class EquilibratedKinematics:
    """``K = [W^T  -J_E]`` (2 n_c, 3 + |tau_I|) scaled for rank tests: ``Kn = diag(1/row) K
    diag(1/col)`` with unit-max columns then unit rows, ``bn = rhs / row`` where ``rhs`` is
    ``J_V thetadot_V`` (eq. 24's right side per constraint row).  A solution ``z'`` of the
    scaled rows gives ``z = z' / col``.  ``b_scale`` is ``max |bn|`` (0 without rows).
    ``KT = K^T`` (3 + |tau_I|, 2 n_c), C-contiguous: ``v = z KT - rhs`` is eq. (5) for row
    vectors ``z = (qdot, thetadot_E)``.  ``thetadot_base (n_theta,)``: the commanded
    velocities of the velocity-controlled joints, 0 at the effort-controlled ones."""

    Kn: np.ndarray
    bn: np.ndarray
    col: np.ndarray
    row: np.ndarray
    rhs: np.ndarray
    velocity_scale: float
    b_scale: float = 0.0
    KT: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    thetadot_base: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: Friction-independent results derived from these rows by other modules (e.g. the
    #: structural test of :func:`planner.predict.indeterminate.closed_bases_suffice`), cached
    #: with the system's set-up.
    derived: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class ForceSetup:
    """Friction-independent data of eq. (26) for one system: the global row scaling ``rs`` of
    ``Q`` (largest ``|G|`` per column of ``G = [W^T  J_E]`` (2 n_c, 3 + |tau_I|), whose rows
    are the loads of unit contact-force components; 0 -> 1), the right side
    ``rhs = [-g_obj; tau_I - g_man_I]`` (:func:`force_rhs`) and ``rhs / rs``;
    ``normal_rows``, ``tangent_rows`` (n_c, 3 + |tau_I|): the normal and the tangent rows of
    ``G``, C-contiguous; ``G`` itself is assembled from them on first use."""

    rs: np.ndarray
    rhs: np.ndarray
    rhs_scaled: np.ndarray
    normal_rows: np.ndarray
    tangent_rows: np.ndarray

    @cached_property
    def G(self) -> np.ndarray:  # noqa: N802 (the paper's symbol)
        """``(2 n_c, 3 + |tau_I|)``: ``[W^T  J_E]``, rows interleaved (normal, tangent)."""
        n_c, q = self.normal_rows.shape
        out = np.empty((2 * n_c, q))
        out[0::2] = self.normal_rows
        out[1::2] = self.tangent_rows
        return out


#: Per-system cache of :func:`system_setup` (a System's
#: arrays are read-only; keyed by identity, so copies of a System do not share it).
_SETUP: weakref.WeakKeyDictionary[System, tuple[EquilibratedKinematics, ForceSetup]] = (
    weakref.WeakKeyDictionary()
)


def system_setup(system: System) -> tuple[EquilibratedKinematics, ForceSetup]:
    """:class:`EquilibratedKinematics` and :class:`ForceSetup` of ``system`` (built together
    once per system: ``K`` and ``G`` differ only in the sign of the ``J_E`` columns)."""
    hit = _SETUP.get(system)
    if hit is None:
        hit = _SETUP[system] = _build_setup(system)
    return hit


def equilibrated_kinematics(system: System) -> EquilibratedKinematics:
    """Build :class:`EquilibratedKinematics` (shared by every kinematic test; cached per
    system, whose arrays are read-only)."""
    return system_setup(system)[0]


def _build_setup(system: System) -> tuple[EquilibratedKinematics, ForceSetup]:
    E, V = system.effort_joints, system.velocity_joints
    J, inputs, n_q = system.J, system.joint_inputs, system.n_q
    k = n_q + len(E)
    # Columns of J laid out as J[:, E] lays them out (Fortran order), without its slow
    # indexing: K below keeps their layout, the row norms and J_V thetadot_V their bits.
    JT = J.T
    J_E, J_V = JT.take(E, axis=0).T, JT.take(V, axis=0).T
    K = np.concatenate([system.W.T, -J_E], axis=1)  # [W^T  -J_E] (rows: constraint rows)
    rhs = J_V @ inputs.take(V)  # J_V thetadot_V per constraint row
    col = np.maximum.reduce(np.abs(K), axis=0)
    _zero_to_one(col)
    Kc = K / col
    row = np.sqrt(np.add.reduce(Kc * Kc, axis=1))  # numpy.linalg.norm(Kc, axis=1)
    _zero_to_one(row)
    bn = rhs / row
    base = inputs.copy()  # thetadot_base
    base[E] = 0.0
    eq = EquilibratedKinematics(
        Kc / row[:, None], bn, col, row, rhs, float(np.maximum.reduce(np.abs(rhs), initial=0.0)),
        float(np.maximum.reduce(np.abs(bn), initial=0.0)), np.ascontiguousarray(K.T), base)
    # G = [W^T  J_E]: K's rows with the J_E columns negated back; its column maxima equal
    # K's (|-x| = |x|), so rs is col.  (2, n_c, k): the normal rows, then the tangent rows.
    G_nt = K.T.reshape(k, J.shape[0] // 2, 2).transpose(2, 1, 0).copy()
    np.negative(G_nt[:, :, n_q:], out=G_nt[:, :, n_q:])
    f_rhs = np.empty(k)  # [-g_obj; tau_I - g_man_I]
    np.negative(system.g_obj, out=f_rhs[:n_q])
    np.subtract(inputs.take(E), system.g_man.take(E), out=f_rhs[n_q:])
    return eq, ForceSetup(col, f_rhs, f_rhs / col, G_nt[0], G_nt[1])


def force_rhs(system: System) -> np.ndarray:
    """Right side of eq. (26): ``[-g_obj; tau_I - g_man_I]``, shape (3 + |tau_I|,)."""
    return system_setup(system)[1].rhs.copy()


def _zero_to_one(x: np.ndarray) -> None:
    """Replace exact zeros of the scaling vector ``x`` by 1, in place."""
    if np.count_nonzero(x) < x.shape[0]:
        x[x == 0] = 1.0
