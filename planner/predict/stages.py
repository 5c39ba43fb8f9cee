"""Kinematic and force stages of the feasibility test, batched over candidate modes.

Eqs. (13)-(16), (23)-(25) (kinematic stage: velocities, breaking contacts separate, sliding
directions ``xi``) and eqs. (18)-(22), (26)-(28) (force stage: ``W_Amu``, contact forces, joint
efforts, Coulomb inequalities) of Trinkle & Zeng (1994), with the tolerances they are judged by
and :class:`FeasibleMode`, the certificate a feasible mode carries.  The tolerance policy is
described in :mod:`planner.predict.feasibility` and ``docs/conventions.md``.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.model.modes import CandidateSet, Mode, enumerate_modes
from planner.model.system import System
from planner.predict.linalg import LU_CHUNK, det_solve, lu_det_solve, transposed_det_solve

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
    joint_velocities : (M, n_theta)
    v : (M, 2 n_c)               relative contact velocities [v_1n, v_1t, ...] (eq. 5).
    xi : (M, n_c) int8           sliding directions (eq. 16), 0 where not sliding.
    margin : (M,)                smallest normalised strict kinematic slack (inf if none).
    ok : (M,) bool               kinematically admissible: margin > tol.
    boundary : (M,) bool         |margin| <= tol (strict constraint on its boundary).
    """

    candidates: CandidateSet
    nonsingular: np.ndarray
    qdot: np.ndarray
    joint_velocities: np.ndarray
    v: np.ndarray
    xi: np.ndarray
    margin: np.ndarray
    ok: np.ndarray
    boundary: np.ndarray
    velocity_scale: float


@dataclass(frozen=True, eq=False)
class EquilibratedKinematics:
    """``K = [W^T  -J_E]`` (2 n_c, 3 + |tau_I|) scaled for rank tests: ``Kn = diag(1/row) K
    diag(1/col)`` with unit-max columns then unit rows, ``bn = rhs / row`` where ``rhs`` is
    ``J_V thetadot_V`` (eq. 24's right side per constraint row).  A solution ``z'`` of the
    scaled rows gives ``z = z' / col``.  ``b_scale`` is ``max |bn|`` (0 without rows)."""

    Kn: np.ndarray
    bn: np.ndarray
    col: np.ndarray
    row: np.ndarray
    rhs: np.ndarray
    velocity_scale: float
    b_scale: float = 0.0


@dataclass(frozen=True, eq=False)
class ForceSetup:
    """Friction-independent data of eq. (26) for one system: ``G = [W^T  J_E]``
    (2 n_c, 3 + |tau_I|), whose rows are the loads of unit contact-force components, the
    global row scaling ``rs`` of ``Q`` (largest ``|G|`` per column, 0 -> 1), the right side
    ``rhs = [-g_obj; tau_I - g_man_I]`` (:func:`force_rhs`) and ``rhs / rs``."""

    G: np.ndarray
    rs: np.ndarray
    rhs: np.ndarray
    rhs_scaled: np.ndarray


#: Per-system cache of :func:`equilibrated_kinematics` and :func:`force_setup` (a System's
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
    WT, J_E = system.W.T, system.J[:, E]
    K = np.concatenate([WT, -J_E], axis=1)
    rhs = system.J[:, V] @ system.joint_inputs[V]  # J_V thetadot_V per constraint row
    vel_scale = float(np.abs(rhs).max()) if rhs.size else 0.0
    col = np.abs(K).max(axis=0)
    col[col == 0] = 1.0
    Kc = K / col
    row = np.sqrt(np.add.reduce(Kc * Kc, axis=1))  # numpy.linalg.norm(Kc, axis=1)
    row[row == 0] = 1.0
    bn = rhs / row
    b_scale = float(np.abs(bn).max()) if bn.size else 0.0
    eq = EquilibratedKinematics(Kc / row[:, None], bn, col, row, rhs, vel_scale, b_scale)
    # G's column maxima equal K's (|-x| = |x|): rs is col.
    f_rhs = np.concatenate([-system.g_obj, system.joint_inputs[E] - system.g_man[E]])
    G = np.concatenate([WT, J_E], axis=1)
    return eq, ForceSetup(G, col, f_rhs, f_rhs / col)


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
    E, V = system.effort_joints, system.velocity_joints
    n_c = system.n_contacts
    M = len(cand)
    # Equilibrate: global column scaling, then unit rows (rows of P_AI are rows of K).
    eq = equilibrated_kinematics(system)
    vel_scale = eq.velocity_scale
    # P_AI = Kn[rows] and its right side bn[rows]; one LU per candidate gives both |det|
    # (30-32) and z (eq. 24).
    det, z = det_solve(eq.Kn, eq.bn, cand.rows)
    nonsingular = np.abs(det) > singular_tol
    all_nonsingular = bool(nonsingular.all())
    if not all_nonsingular:
        z[~nonsingular] = np.nan
    z /= eq.col
    n_q = system.n_q  # 3 n_b
    qdot = z[:, :n_q]
    thetadot = np.empty((M, system.n_joints))
    thetadot[:, V] = system.joint_inputs[V]
    thetadot[:, E] = z[:, n_q:]
    v = qdot @ system.W - thetadot @ system.J.T  # (M, 2 n_c), eq. (5)
    v_n, v_t = v[:, 0::2], v[:, 1::2]
    is_break, is_slide, _ = cand.masks
    scale = vel_scale if vel_scale > 0 else 1.0
    strict = np.where(is_break, v_n, np.where(is_slide, np.abs(v_t), np.inf))
    margin = strict.min(axis=1) / scale if n_c else np.full(M, np.inf)
    # xi = sgn(v_t) (eq. 16) at sliding contacts of nonsingular candidates; NaN counts as 0.
    xi = (v_t > 0).view(np.int8) - (v_t < 0).view(np.int8)
    if all_nonsingular:
        xi *= is_slide
    else:
        margin[~nonsingular] = -np.inf
        xi *= is_slide & nonsingular[:, None]
    ok = margin > tol  # singular candidates have margin -inf
    boundary = np.abs(margin) <= tol
    return KinematicStage(cand, nonsingular, qdot, thetadot, v, xi, margin, ok, boundary, vel_scale)


# ---------------------------------------------------------------------------------------------
# Force stage (eqs. 17-22, 26-28): friction enters here.
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ForceStage:
    """Forces of a subset of candidates for one or many friction vectors.

    Shapes use ``L`` friction vectors and ``m`` modes: ``c_A (L, m, k)``, ``contact_forces
    (L, m, n_c, 2)``, ``joint_efforts (L, m, n_theta)``, ``margin (L, m)``,
    ``nonsingular (L, m)``.
    """

    c_A: np.ndarray  # noqa: N815 (the paper's symbol)
    contact_forces: np.ndarray
    joint_efforts: np.ndarray
    margin: np.ndarray
    nonsingular: np.ndarray


def force_rhs(system: System) -> np.ndarray:
    """Right side of eq. (26): ``[-g_obj; tau_I - g_man_I]``, shape (3 + |tau_I|,)."""
    return system_setup(system)[1].rhs.copy()


def force_setup(system: System) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(G, rs, rhs)`` of :class:`ForceSetup` (cached per system)."""
    fs = system_setup(system)[1]
    return fs.G, fs.rs, fs.rhs


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
    return _force_matrices(system_setup(system)[1].G, rows, sliding, contact,
                           2 * contact + 1, xi, mu)


def _force_matrices(
    G: np.ndarray, rows: np.ndarray, sliding: np.ndarray, contact: np.ndarray,
    tangent_rows: np.ndarray, xi: np.ndarray, mu: np.ndarray,
) -> np.ndarray:
    base = G[rows]  # (m, k, q)
    tang = G[tangent_rows]  # tangent row of the same contact
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
) -> ForceStage:
    """Solve eq. (26) and test eq. (28) for candidates ``index`` at friction vectors ``mu``.

    ``xi`` is ``(len(index), n_c)``; ``mu`` is ``(n_c,)`` or ``(L, n_c)``.
    """
    mu2 = np.atleast_2d(np.asarray(mu, dtype=float))
    L = mu2.shape[0]
    n_c, k = system.n_contacts, candidates.n_rows
    rows = candidates.rows[index]
    contact = candidates.contact[index]
    _, slide_mask, roll_mask = candidates.masks
    is_s, is_r = slide_mask[index], roll_mask[index]
    m = rows.shape[0]
    setup = system_setup(system)[1]
    QT = _force_matrices(setup.G, rows, candidates.sliding[index], contact,
                         candidates.tangent_rows[index], xi, mu2)  # (L, m, k, k)
    # Equilibrate: global scaling of Q's rows (columns of QT), unit columns of Q per mode.
    QT /= setup.rs
    cn = np.sqrt(np.einsum("...i,...i->...", QT, QT))  # (L, m, k) column norms
    cn[cn == 0] = 1.0
    QT /= cn[..., None]
    # Q_AI = QTn^T per mode: one LU per matrix gives |det| (30-32) and y (eq. 26).
    det, y = transposed_det_solve(QT.reshape(L * m, k, k), setup.rhs_scaled)
    nonsingular = (np.abs(det) > singular_tol).reshape(L, m)
    y = y.reshape(L, m, k)
    all_nonsingular = bool(nonsingular.all())
    if not all_nonsingular:
        y[~nonsingular] = np.nan
    c_A = y / cn
    # Scatter to full contact forces; sliding tangential force c_t = -mu xi c_n (eq. 17).
    c_full = np.zeros((L, m, 2 * n_c))
    c_full[:, np.arange(m)[:, None], rows] = c_A
    cn_all = c_full[..., 0::2]
    c_full[..., 1::2] += np.where(is_s, -mu2[:, None, :] * xi * cn_all, 0.0)
    forces = c_full.reshape(L, m, n_c, 2)
    efforts = c_full @ system.J + system.g_man  # eq. (3): tau = J^T c + g_man
    # Coulomb (eqs. 21-22): rolling mu c_n - |c_t| >= 0, sliding c_n >= 0.
    fn, ft = forces[..., 0], forces[..., 1]
    # A rolling contact also needs c_n >= 0 (implied by the cone only when mu > 0).
    slack = np.where(
        is_r, np.minimum(mu2[:, None, :] * fn - np.abs(ft), fn), np.where(is_s, fn, np.inf),
    )
    f_scale = np.abs(c_A).max(axis=-1) if k else np.zeros((L, m))
    f_scale[~(f_scale > 0)] = 1.0  # zero or NaN (singular)
    margin = slack.min(axis=-1) / f_scale if n_c else np.full((L, m), np.inf)
    if not all_nonsingular:
        margin[~nonsingular] = -np.inf
    return ForceStage(c_A, forces, efforts, margin, nonsingular)


# ---------------------------------------------------------------------------------------------
