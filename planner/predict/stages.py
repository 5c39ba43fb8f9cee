"""Kinematic and force stages of the feasibility test, batched over candidate modes.

Eqs. (13)-(16), (23)-(25) (kinematic stage: velocities, breaking contacts separate, sliding
directions ``xi``) and eqs. (18)-(22), (26)-(28) (force stage: ``W_Amu``, contact forces, joint
efforts, Coulomb inequalities) of Trinkle & Zeng (1994), with the tolerances they are judged by
and :class:`FeasibleMode`, the certificate a feasible mode carries.  The tolerance policy is
described in :mod:`planner.predict.feasibility` and ``docs/conventions.md``.  The per-system
set-up they share (equilibrated ``K``, the rows of ``G``) is :mod:`planner.predict.setup`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import Any

import numpy as np

from planner.model.modes import CandidateSet, Mode, enumerate_modes
from planner.model.system import System
from planner.predict.linalg import LU_CHUNK, det_solve, lu_det_solve, transposed_det_solve
from planner.predict.setup import (
    EquilibratedKinematics,
    ForceSetup,
    equilibrated_kinematics,
    force_rhs,
    system_setup,
)

__all__ = [
    "DEFAULT_SINGULAR_TOL", "DEFAULT_TOL", "EquilibratedKinematics", "FeasibleMode",
    "ForceSetup", "ForceStage", "KinematicStage", "LU_CHUNK", "equilibrated_kinematics",
    "force_matrices", "force_rhs", "force_stage", "kinematic_stage", "lu_det_solve",
    "system_setup",
]

#: Default relative tolerance on normalised constraint slacks.
DEFAULT_TOL = 1e-9
#: Equilibrated |det| below which P_AI or Q_AI is treated as singular (conditions 30-32).
DEFAULT_SINGULAR_TOL = 1e-10
#: Smallest positive normal double: a zero column norm becomes this (the column stays 0).
_TINY = float(np.finfo(float).tiny)


@dataclass(frozen=True, eq=False)
class FeasibleMode:
    """A feasible contact mode with its certificate.

    Attributes
    ----------
    mode : Mode
        Contact interactions and sliding directions.
    qdot : (3 n_b,) [m/s, m/s, rad/s]
        Workpiece velocity (point at the world origin), world frame, per body.
    joint_velocities : (n_theta,)
        All joint velocities (given ones and the solved ones of effort-controlled joints).
    contact_velocities : (n_c, 2) [m/s]
        Relative velocities ``v_i = (v_in, v_it)`` (eq. 5), contact frames.
    contact_forces : (n_c, 2) [N]
        ``c_i = (c_in, c_it)`` on the workpiece, contact frames (zero at breaking contacts).
    joint_efforts : (n_theta,)
        All joint efforts ``tau = J^T c + g_man`` (eq. 3).
    margin : float
        Smallest normalised constraint slack (see the module's tolerance policy).
    on_boundary : bool
        ``|margin| <= tol``: the mode sits on the boundary of its feasible region.
    force_indeterminate : bool
        True for relaxed-utility modes whose forces are not unique (certificate is one
        feasible force distribution, the one of largest margin).
    """

    mode: Mode
    qdot: np.ndarray
    joint_velocities: np.ndarray
    contact_velocities: np.ndarray
    contact_forces: np.ndarray
    joint_efforts: np.ndarray
    margin: float
    on_boundary: bool = False
    force_indeterminate: bool = False

    @property
    def label(self) -> str:
        return self.mode.label

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready certificate (the ``qsplan modes --json`` schema)."""
        return {
            "mode": self.mode.label,
            "family": self.mode.family,
            "qdot": self.qdot.tolist(),
            "joint_velocities": self.joint_velocities.tolist(),
            "contact_velocities": self.contact_velocities.tolist(),
            "contact_forces": self.contact_forces.tolist(),
            "joint_efforts": self.joint_efforts.tolist(),
            "margin": float(self.margin),
            "on_boundary": bool(self.on_boundary),
            "force_indeterminate": bool(self.force_indeterminate),
        }


# ---------------------------------------------------------------------------------------------
# Kinematic stage (eqs. 13-16, 23-25): independent of friction.
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class KinematicStage:
    """Kinematic solution of every candidate (arrays indexed by candidate).

    Attributes
    ----------
    candidates : CandidateSet
    nonsingular : (M,) bool      P_AI invertible (conditions 30, 32).
    qdot : (M, 3 n_b)            workpiece velocities (NaN where singular).
    effort_velocities : (M, |tau_I|)  velocities of the effort-controlled joints (eq. 24).
    v : (M, 2 n_c)               relative contact velocities [v_1n, v_1t, ...] (eq. 5).
    xi : (M, n_c) int8           sliding directions (eq. 16), 0 where not sliding.
    margin : (M,)                smallest normalised strict kinematic slack (inf if none).
    ok : (M,) bool               kinematically admissible: margin > tol.
    boundary : (M,) bool         |margin| <= tol (strict constraint on its boundary).
    velocity_scale : float       largest commanded contact-point speed (the margin's unit).
    thetadot_base : (n_theta,)   commanded joint velocities, 0 at effort-controlled joints.
    effort_joints : (|tau_I|,)   their indices.
    det : (M,)                   equilibrated determinant of P_AI (rank test 30-32).
    joint_velocities : (M, n_theta)  all joint velocities (built on first use).
    """

    candidates: CandidateSet
    nonsingular: np.ndarray
    qdot: np.ndarray
    effort_velocities: np.ndarray
    v: np.ndarray
    xi: np.ndarray
    margin: np.ndarray
    ok: np.ndarray
    boundary: np.ndarray
    velocity_scale: float
    thetadot_base: np.ndarray
    effort_joints: np.ndarray
    det: np.ndarray

    @cached_property
    def joint_velocities(self) -> np.ndarray:
        """``(M, n_theta)``: the given velocities and the solved ones of effort joints."""
        out = np.repeat(self.thetadot_base[None], self.qdot.shape[0], axis=0)
        out[:, self.effort_joints] = self.effort_velocities
        return out

    def joint_velocities_of(self, i: int) -> np.ndarray:
        """``(n_theta,)``: :attr:`joint_velocities` of candidate ``i`` (a new array)."""
        out = self.thetadot_base.copy()
        out[self.effort_joints] = self.effort_velocities[i]
        return out


@lru_cache(maxsize=256)
def _row_offsets(P: int, stride: int) -> np.ndarray:
    """``(P, 1)``: ``0, stride, 2 stride, ...`` (read-only; the flat row offset of each pair)."""
    out = np.arange(0, P * stride, stride)[:, None]
    out.setflags(write=False)
    return out


def kinematic_stage(
    system: System,
    candidates: CandidateSet | None = None,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
) -> KinematicStage:
    """Solve eqs. (13), (23)-(24) for every candidate and test eq. (25) and ``xi`` (eq. 16).

    ``P_AI = [W_A^T  -J_AE]`` with ``W_A^T`` the applicable rows of ``W^T`` (eq. 14) and
    ``J_AE`` the applicable rows of the effort-controlled joints' Jacobian columns; the right
    side is ``J_AV thetadot_V``.
    """
    cand = candidates if candidates is not None else enumerate_modes(system.n_contacts, system.dof)
    M = len(cand)
    # Equilibrate: global column scaling, then unit rows (rows of P_AI are rows of K).
    eq = system_setup(system)[0]
    vel_scale = eq.velocity_scale
    # P_AI = Kn[rows] and its right side bn[rows]; one LU per candidate gives both |det|
    # (30-32) and z (eq. 24).
    det, z = det_solve(eq.Kn, eq.bn, cand.rows)
    nonsingular = np.abs(det) > singular_tol
    all_nonsingular = np.count_nonzero(nonsingular) == M
    if not all_nonsingular:
        z[~nonsingular] = np.nan
    z /= eq.col
    v = z @ eq.KT  # (M, 2 n_c), eq. (5): v = W^T qdot - J_E thetadot_E - J_V thetadot_V
    v -= eq.rhs
    # Strict slacks: v_n of breaking contacts (eq. 25), |v_t| of sliding ones (eq. 16).
    slack = np.abs(v)
    slack[:, 0::2] = v[:, 0::2]
    margin = np.minimum.reduce(slack, axis=1, where=cand.strict_rows, initial=np.inf)
    if vel_scale > 0:
        margin /= vel_scale
    # xi = sgn(v_t) (eq. 16) at sliding contacts; 0 where v_t is NaN (singular candidates).
    v_t = v[:, 1::2]
    xi = np.greater(v_t, 0.0).view(np.int8)
    xi -= np.less(v_t, 0.0).view(np.int8)
    xi *= cand.masks[1].view(np.int8)
    if not all_nonsingular:
        margin[~nonsingular] = -np.inf
    ok = margin > tol  # singular candidates have margin -inf
    boundary = np.abs(margin) <= tol
    n_q = system.n_q  # 3 n_b
    return KinematicStage(cand, nonsingular, z[:, :n_q], z[:, n_q:], v, xi, margin, ok, boundary,
                          vel_scale, eq.thetadot_base, system.effort_joints, det)


# ---------------------------------------------------------------------------------------------
# Force stage (eqs. 17-22, 26-28): friction enters here.
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ForceStage:
    """Forces of a subset of candidates for one or many friction vectors.

    Shapes use ``L`` friction vectors and ``m`` modes: ``c_A (L, m, k)``, ``contact_forces
    (L, m, n_c, 2)``, ``joint_efforts (L, m, n_theta)``, ``margin (L, m)``,
    ``nonsingular (L, m)``, ``force_scale (L, m)``: the largest ``|c_A|`` of each (the unit of
    the margin; NaN where singular, at least the smallest normal double).
    """

    c_A: np.ndarray  # noqa: N815 (the paper's symbol)
    contact_forces: np.ndarray
    joint_efforts: np.ndarray
    margin: np.ndarray
    nonsingular: np.ndarray
    force_scale: np.ndarray


def force_matrices(
    system: System, rows: np.ndarray, sliding: np.ndarray, contact: np.ndarray,
    xi: np.ndarray, mu: np.ndarray,
) -> np.ndarray:
    """``Q_AI^T`` for modes given by constraint rows, batched (eqs. 18-20, 26).

    Parameters
    ----------
    rows, sliding, contact : (m, k)
        Candidate rows (see :class:`planner.model.modes.CandidateSet`).
    xi : (m, n_c)
        Sliding directions.
    mu : (L, n_c)
        Friction vectors.

    Returns
    -------
    QT : (L, m, k, 3 + |tau_I|)
        Row ``j`` is the wrench and effort-joint load of unit ``c_A[j]``: ``[w; j_E]`` of its
        row, minus ``mu_i xi_i [w_t; j_tE]`` when it is a sliding contact's normal (eq. 17).
    """
    G = system_setup(system)[1].G
    base = G[rows]  # (m, k, q)
    tang = G[2 * contact + 1]  # tangent row of the same contact
    xi_rows = xi[np.arange(xi.shape[0])[:, None], contact].astype(float)  # (m, k)
    coef = mu[:, contact] * (xi_rows * sliding)[None]  # (L, m, k)
    return base[None] - coef[..., None] * tang[None]


def force_stage(
    system: System,
    candidates: CandidateSet,
    index: np.ndarray,
    xi: np.ndarray,
    mu: np.ndarray,
    *,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    tol: float = DEFAULT_TOL,
) -> ForceStage:
    """Solve eq. (26) and test eq. (28) for candidates ``index`` at friction vectors ``mu``.

    ``xi`` is ``(len(index), n_c)``: the kinematic stage's sliding directions
    (:attr:`KinematicStage.xi`: ``sgn v_t`` at sliding contacts, 0 at the others); ``mu`` is
    ``(n_c,)`` or ``(L, n_c)``.  A rolling contact with ``mu_i = 0`` has the equality
    ``c_it = 0`` instead of a cone (no slip boundary exists): it holds when ``|c_it| <= tol``
    times the mode's largest force and then takes no part in the margin.
    """
    mu2 = np.asarray(mu, dtype=float)
    if mu2.ndim != 2:
        mu2 = mu2.reshape(1, -1)
    L, m = mu2.shape[0], len(index)
    n_c, k = system.n_contacts, candidates.n_rows
    P = L * m  # (friction vector, candidate) pairs, friction-major
    setup = system_setup(system)[1]
    rows = candidates.rows.take(index, axis=0)
    _, slide_mask, roll_mask = candidates.masks
    is_s, is_r = slide_mask.take(index, axis=0), roll_mask.take(index, axis=0)
    if L == 1:
        mu_p = mu2  # broadcasts over the m pairs
        muxi = mu2 * xi  # (P, n_c): mu_i xi_i (0 unless sliding)
    else:
        mu_p = np.repeat(mu2, m, axis=0)
        muxi = mu_p * np.tile(xi, (L, 1))
        rows, is_s, is_r = np.tile(rows, (L, 1)), np.tile(is_s, (L, 1)), np.tile(is_r, (L, 1))
    # Q_AI^T (eqs. 17-20, 26): the rows of G, a sliding contact's normal row minus mu_i xi_i
    # times its tangent row.
    Gn, Gt = setup.normal_rows, setup.tangent_rows  # (n_c, q)
    Gmu = np.empty((P, n_c, 2, Gn.shape[1]))
    Gmu[:, :, 1] = Gt
    np.subtract(Gn, muxi[..., None] * Gt, out=Gmu[:, :, 0])
    flat = _row_offsets(P, 2 * n_c) + rows  # (P, k) into (P * 2 n_c)
    QT = Gmu.reshape(P * 2 * n_c, Gn.shape[1]).take(flat, axis=0)  # (P, k, k)
    # Equilibrate: global scaling of Q's rows (columns of QT), then unit columns of Q per mode
    # (a zero column stays zero: singular).
    QT /= setup.rs
    cn = np.sqrt(np.einsum("...i,...i->...", QT, QT))  # (P, k) column norms
    if np.count_nonzero(cn) < cn.size:
        np.maximum(cn, _TINY, out=cn)
    QT /= cn[..., None]
    # Q_AI = QTn^T per mode: one LU per matrix gives |det| (30-32) and y (eq. 26).
    det, y = transposed_det_solve(QT, setup.rhs_scaled)
    nonsingular = np.abs(det) > singular_tol
    all_nonsingular = np.count_nonzero(nonsingular) == P
    if not all_nonsingular:
        y[~nonsingular] = np.nan
    c_A = y / cn
    # Scatter to full contact forces; sliding tangential force c_t = -mu xi c_n (eq. 17).
    c_full = np.zeros((P, 2 * n_c))
    c_full.put(flat, c_A)
    fn, ft = c_full[:, 0::2], c_full[:, 1::2]
    ft -= muxi * fn
    # eq. (3): tau = J^T c + g_man (stacked: a 2-D product starts BLAS threads, docs/scaling.md)
    efforts = c_full.reshape(L, m, 2 * n_c) @ system.J
    efforts += system.g_man
    # Coulomb (eqs. 21-22): rolling mu c_n - |c_t| >= 0, sliding c_n >= 0.
    # A rolling contact also needs c_n >= 0 (implied by the cone only when mu > 0).
    cone = mu_p * fn
    cone -= np.abs(ft)
    if k and n_c:
        # Largest applicable force; 0 -> _TINY (all forces 0: the slacks are 0 or inf).
        f_scale = np.maximum.reduce(np.abs(c_A), axis=1)
        frictionless = is_r & (mu_p == 0.0)
        if np.any(frictionless):  # c_t = 0 is an equality: no boundary, no margin
            held = np.abs(ft) <= tol * np.maximum(f_scale, _TINY)[:, None]
            cone = np.where(frictionless & held, np.inf, cone)
        slack = np.where(is_r, np.minimum(cone, fn), np.where(is_s, fn, np.inf))
        margin = np.minimum.reduce(slack, axis=1)
        margin /= np.maximum(f_scale, _TINY, out=f_scale)
    else:
        margin, f_scale = np.full(P, np.inf), np.full(P, _TINY)
    if not all_nonsingular:
        margin[~nonsingular] = -np.inf
    return ForceStage(c_A.reshape(L, m, k), c_full.reshape(L, m, n_c, 2), efforts,
                      margin.reshape(L, m), nonsingular.reshape(L, m), f_scale.reshape(L, m))
