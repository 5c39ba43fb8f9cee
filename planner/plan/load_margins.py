"""How much mass and centre-of-mass uncertainty a plan's commands tolerate (eq. 28 over the set).

:func:`command_guaranteed` decides, at one waypoint, whether the *commanded* efforts make the
claimed mode the only possible one for every friction in the segment's box and every load of a
:class:`planner.model.load_set.LoadSet` (docs/planning.md, "Uncertainty beyond friction"):

* one effort joint: the command lies in a piece of the guaranteed band
  (:func:`planner.plan.guarantee.guarantee` with the set's vertex loads);
* any other number: the claim's Coulomb rows hold at every friction corner x vertex load (exact:
  a row is multilinear in ``mu`` and affine in the load) and every determinate rival has one row
  that fails at all those points (the one-row exclusion of :mod:`planner.plan.polytope`, checked
  exactly); a force-indeterminate rival is infeasible at every corner over the whole load hull
  (a linear program per corner; the corners only, as in the polytope region).  A mode whose
  ``det Q_AI`` changes sign over the corners is checked at the corners and a 3-point grid, as
  :func:`planner.plan.polytope.torque_region` does (not exact; the plan says so).

:func:`tolerated` widens one axis of the set at a time -- the mass to ``m0 +- d`` [kg], both
centre-of-mass coordinates to ``c0 +- d`` [m], or every contact's position along its feature to
``+- d`` [m] (:mod:`planner.plan.offset_bounds`; plans whose segments all have one effort joint)
-- the others kept as planned, and searches the largest ``d`` every waypoint keeps.  The sets
are nested, so each waypoint's test is monotone in ``d``: the search's lower end is certified
(every waypoint holds there; the value reported) and a waypoint fails at its upper end,
``resolution`` above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import linprog

from planner.errors import DegenerateError
from planner.model.hand import Hand
from planner.model.load_set import LoadSet, point_set
from planner.model.validation import friction_interval
from planner.plan.bounds import admissible_modes, affine_rows, box_points
from planner.plan.guarantee import guarantee, resolve_claim
from planner.plan.load_bounds import concat_rows, with_load
from planner.plan.model import Plan
from planner.plan.offset_bounds import offset_box
from planner.plan.partition import joint_inputs
from planner.predict.indeterminate import coulomb_rows, indeterminate_kinematics
from planner.predict.stages import DEFAULT_TOL, force_matrices


def command_guaranteed(hand: Hand, q: np.ndarray, V: tuple[int, ...], rates: Any, claim: str,
                       mu: Any, model: str, tau: Any, *, tol: float = DEFAULT_TOL) -> bool:
    """True when the efforts ``tau (p,)`` at configuration ``q`` with the joints ``V`` at
    ``rates`` guarantee ``claim`` for every friction in ``mu`` and every load of
    ``hand.load_set`` (module docstring).  Stage failures count as not guaranteed."""
    try:
        return _guaranteed(hand, q, V, rates, claim, mu, model, np.asarray(tau, float), tol)
    except DegenerateError:
        return False


def _guaranteed(hand: Hand, q: np.ndarray, V: tuple[int, ...], rates: Any, claim: str, mu: Any,
                model: str, tau: np.ndarray, tol: float) -> bool:
    joints = joint_inputs(hand, V, rates)
    system = hand.system(q, 0.0, joints)
    loads = hand.load_vertices(q)
    G = np.asarray(system.g_obj)[None] if loads is None else loads
    p = len(system.effort_joints)
    box = offset_box(hand, q, joints)
    if p == 1:
        g = guarantee(system, claim, mu, model=model, tol=tol, loads=loads, box=box)
        return any(piece.contains(float(tau[0])) for piece in g.pieces)
    if box is not None:  # contact positions: one effort joint only (docs/planning.md)
        return False
    lo, hi = friction_interval(mu, system.n_contacts)
    corners, grid = box_points(lo, hi, 3)
    stage, index = admissible_modes(system, tol=tol)

    def rows_at(pts: np.ndarray) -> Any:
        return concat_rows([affine_rows(with_load(system, w), pts, stage=stage, index=index)
                            for w in G])

    rows = rows_at(corners)
    rows_g = None
    kins = indeterminate_kinematics(system, tol=tol)
    labels = [m.label for m in rows.modes]
    label = resolve_claim(claim, labels + [k.mode.label for k in kins],
                          [m.family for m in rows.modes] + [k.mode.family for k in kins])
    if label not in labels:
        return False
    for j in [labels.index(label)] + [j for j in range(len(labels)) if labels[j] != label]:
        r = rows
        d = rows.det[:, j]
        if not (np.all(d > 0) or np.all(d < 0)):  # as torque_region: corners and its grid
            rows_g = rows_g if rows_g is not None else rows_at(np.concatenate([corners, grid]))
            r = rows_g
        slack = r.s0[:, j] + (r.s1[:, j] @ tau if p else 0.0)  # (L, 3 n_c)
        act, live = r.active[j], r.det[:, j] != 0
        sc = tol * r.scale[live, j, None]
        if labels[j] == label:
            if not live.all() or np.any(slack[:, act] < -sc):
                return False
        elif live.any() and not np.any(np.all(slack[live][:, act] < -sc, axis=0)):
            return False
    corner_mu = np.unique(corners, axis=0)
    return not any(kin.mode.label != label and _indeterminate_possible(system, kin, m, G, tau)
                   for kin in kins for m in corner_mu)


def _indeterminate_possible(system: Any, kin: Any, mu_v: np.ndarray, G: np.ndarray,
                            tau: np.ndarray) -> bool:
    """Feasibility LP of a force-indeterminate mode at friction ``mu_v`` and efforts ``tau``
    over the hull of the loads ``G (K, n_q)`` (eqs. 21-22, 26)."""
    QT = force_matrices(system, kin.rows[None], kin.sliding[None], kin.contact[None],
                        kin.xi[None], mu_v[None])[0, 0]
    Q = QT.T
    k, n_rows = Q.shape
    K, n_q = G.shape
    E = system.effort_joints
    L = np.zeros((k, K))
    L[:n_q] = G.T
    A_eq = np.vstack([np.hstack([Q, L]), np.r_[np.zeros(n_rows), np.ones(K)][None]])
    b_eq = np.r_[np.zeros(n_q), tau - system.g_man[E], 1.0]
    B = coulomb_rows(kin.rows, kin.sliding, kin.contact, kin.codes, mu_v)
    res = linprog(np.zeros(n_rows + K), A_ub=np.hstack([-B, np.zeros((len(B), K))]),
                  b_ub=np.zeros(len(B)), A_eq=A_eq, b_eq=b_eq,
                  bounds=[(None, None)] * n_rows + [(0.0, None)] * K, method="highs")
    return bool(res.status != 2)


@dataclass(frozen=True)
class Tolerance:
    """The largest symmetric uncertainty of each axis a plan's commands tolerate, the other
    axis as planned: ``mass_kg`` (``m0 +- mass_kg``) and ``com_m`` (``c0 +- com_m`` in both
    body-frame coordinates); each the certified lower end of a bisection whose upper end is
    ``resolution`` above (``math.inf``: tolerated up to the search's cap -- the whole nominal
    mass, the workpiece's size)."""

    mass_kg: float
    com_m: float
    mass_resolution_kg: float
    com_resolution_m: float
    contacts_m: float | None = None
    contacts_resolution_m: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        def fin(x: float | None) -> float | None:
            return x if x is not None and math.isfinite(x) else None
        return {"mass_kg": fin(self.mass_kg), "com_m": fin(self.com_m),
                "mass_resolution_kg": self.mass_resolution_kg,
                "com_resolution_m": self.com_resolution_m,
                "contacts_m": fin(self.contacts_m),
                "contacts_resolution_m": self.contacts_resolution_m,
                "contacts_computed": self.contacts_m is not None,
                "method": "bisection on the exact guarantee of the commands at every waypoint"}

    def words(self) -> str:
        m = "all of it" if not math.isfinite(self.mass_kg) else f"+-{self.mass_kg:.4g} kg"
        c = ("the workpiece's size" if not math.isfinite(self.com_m)
             else f"+-{1000 * self.com_m:.3g} mm")
        p = ("" if self.contacts_m is None else ", contact positions the workpiece's size"
             if not math.isfinite(self.contacts_m)
             else f", contact positions +-{1000 * self.contacts_m:.3g} mm")
        return (f"tolerates mass {m}, centre of mass {c}{p} (each axis alone, the others as "
                "planned)")


def plan_load_set(plan: Plan) -> LoadSet | None:
    """The plan's mass / centre-of-mass set (its hand's ``uncertainty``; None: none given)."""
    if not plan.segments:
        return None
    return plan.segments[0].hand_model[0].load_set


def _waypoints(plan: Plan) -> list[tuple[Any, ...]]:
    """Per waypoint ``(segment, waypoint)``, the smallest relative margin first (the likeliest
    to bind the tolerance)."""
    out = []
    for seg in plan.segments:
        for w in seg.waypoints:
            size = float(np.linalg.norm(w.torque_commands)) if len(w.torque_commands) else 1.0
            out.append((w.margin / max(size, 1e-300), seg, w))
    out.sort(key=lambda x: x[0])
    return [(seg, w) for _, seg, w in out]


def waypoint_holds(plan: Plan, seg: Any, w: Any, load_set: LoadSet) -> bool:
    """:func:`command_guaranteed` of one waypoint's commands over ``load_set`` (the segment's
    friction box, the plan's friction model)."""
    hand = replace(seg.hand_model[0], load_set=load_set)
    return command_guaranteed(hand, np.concatenate([w.pose, w.angles]), seg.velocity_joints,
                              w.velocity_commands, seg.claim, list(seg.mu_intervals),
                              plan.mu_model, w.torque_commands)


def holds(plan: Plan, load_set: LoadSet) -> bool:
    """True when every waypoint's commands are guaranteed over ``load_set``."""
    return all(waypoint_holds(plan, seg, w, load_set) for seg, w in _waypoints(plan))


def tolerated(plan: Plan, *, steps: int = 10) -> Tolerance:
    """The largest half-width of each axis that every waypoint keeps (module docstring), to
    ``cap / 2**steps`` (``cap``: the nominal mass; the workpiece's size).

    Waypoints are taken in turn with a bracket ``[lo, hi)``: every waypoint so far holds at
    ``lo`` and one fails at ``hi``.  A waypoint that holds at ``lo`` leaves it (its own
    tolerance is at least ``lo``); one that fails there is bisected on ``[0, lo]``, which
    lowers ``lo`` (the earlier ones still hold: the sets are nested) and sets ``hi``."""
    if not plan.segments:
        return Tolerance(0.0, 0.0, 0.0, 0.0)
    hand = plan.segments[0].hand_model[0]
    base = hand.load_set or point_set(hand.mass, hand.com)
    wps = _waypoints(plan)
    out, res = [], []
    axes = [("mass", hand.mass), ("com", hand.length_scale)]
    one_effort = all(len(seg.effort_joints) == 1 for seg in plan.segments)
    if one_effort:
        axes.append(("contacts", hand.length_scale))
    for axis, cap in axes:
        step = cap / 2 ** steps
        lo, hi = cap, math.inf

        def ok(seg: Any, w: Any, d: float, axis: str = axis) -> bool:
            return waypoint_holds(plan, seg, w, base.widened(axis, d))

        for seg, w in wps:
            if ok(seg, w, lo):
                continue
            a, b = 0.0, lo
            if not ok(seg, w, a):
                lo, hi = 0.0, 0.0
                break
            while b - a > step:
                mid = 0.5 * (a + b)
                a, b = (mid, b) if ok(seg, w, mid) else (a, mid)
            lo, hi = a, b
        out.append(math.inf if lo == cap else lo)
        res.append(0.0 if not math.isfinite(hi) else hi - lo)
    if not one_effort:  # contact positions: one effort joint only (docs/planning.md)
        return Tolerance(out[0], out[1], res[0], res[1])
    return Tolerance(out[0], out[1], res[0], res[1], out[2], res[2])
