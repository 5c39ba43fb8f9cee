"""Control partitions (Section 3.2) and the guaranteed effort set at each waypoint (eq. 28).

A determinate mode with ``n_R`` rolling and ``n_S`` sliding contacts has ``k = 2 n_R + n_S``
contact unknowns; condition (29) asks ``3 <= k <= 3 + n_theta`` and condition (32) a square,
non-singular ``Q_AI``, so exactly ``p = k - 3`` joints are effort-controlled (``tau_I``) and the
other ``n_theta - p`` velocity-controlled (``zdot_II``, eq. 24).  A force-indeterminate mode
(relaxed utility, end of Sec. 3.2: more rows than ``3 + |tau_I|``, e.g. two sticking contacts of
one rigid finger face) is admitted by the rank of its rows, not their count: with ``r`` the rank
of eq. 5's rows of its maintained contacts (:func:`mode_rows`), ``p = r - 3`` joints are
effort-controlled, chosen so that the workpiece twist and their rates are fixed by the rows
(``[W_A^T, -J_AI]`` of rank ``r = 3 + p``: ``P_A`` of full column rank) and every rate of the
others is consistent with them (the velocity-controlled columns lie in that range, as the rank
of all rows is ``r``).  :func:`control_partitions` lists every such choice.  For one
partition, at each waypoint, :func:`guaranteed_at` gives the efforts that guarantee the mode and
exclude every rival over the friction set:

* ``p = 1``: the band of :func:`planner.plan.guarantee.guarantee` (the exact friction
  dependence; Figures 11-13), kept whole (:attr:`Guaranteed.guarantee`) because it may have
  several pieces: the piece a waypoint uses is chosen along the segment
  (:func:`choose_pieces`: the widest piece overlapping the previous waypoint's, else the
  widest);
* any ``p``: the polytope of :func:`planner.plan.polytope.torque_region` over the friction box
  (``p = 0``: the mode is guaranteed or not; the margin is the smallest normalised Coulomb
  slack).

Units: efforts in the joints' units (N m revolute, N prismatic).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.closure import constraint_rank, contact_rate_rows
from planner.model.hand import Hand
from planner.model.modes import BREAK, ROLL, Mode
from planner.plan.guarantee import Guarantee, guarantee
from planner.plan.intervals import EMPTY, Interval
from planner.plan.offset_bounds import offset_box
from planner.plan.polytope import TorqueRegion, band_region, empty_region, torque_region
from planner.predict.feasibility import feasible_modes


def mode_unknowns(label: str) -> int:
    """``k = 2 n_R + n_S`` of a mode label such as ``"S+1 R2 B3"`` (conditions 29, 32)."""
    return sum(2 if t.startswith("R") else 1 if t.startswith("S") else 0 for t in label.split())


def mode_rows(hand: Hand, q: np.ndarray, label: str) -> np.ndarray:
    """``(2 n_R + n_S, 3 + n_theta)``: eq. 5's rows of the maintained contacts of mode ``label``
    at ``q`` per state rate ``d/dt (x, y, phi, theta)`` -- the normal row of every ``R`` and
    ``S`` contact, then the tangential row of every ``R`` contact (eqs. 13-14); ``B`` contacts
    give none (eq. 16)."""
    codes = Mode.parse(label, hand.n_contacts).codes
    normal = [i for i, c in enumerate(codes) if c != BREAK]
    sticking = [i for i, c in enumerate(codes) if c == ROLL]
    return np.vstack([contact_rate_rows(hand, q, 0)[normal],
                      contact_rate_rows(hand, q, 1)[sticking]])


def control_partitions(n_joints: int, label: str, rows: np.ndarray | None = None
                       ) -> list[tuple[tuple[int, ...], tuple[int, ...]]]:
    """Every ``(velocity joints, effort joints)`` split with ``|tau_I| = k - 3`` (eqs. 29, 32).

    A mode with more rows than ``3 + n_theta`` is force-indeterminate (relaxed utility, end of
    Sec. 3.2): given its ``rows`` (:func:`mode_rows`, ``(k, 3 + n_theta)``) the split has
    ``|tau_I| = r - 3`` effort joints, ``r`` the rank of the rows, and only the splits whose
    effort columns with the workpiece's have rank ``r`` are listed (module docstring).  A mode
    of at most ``3 + n_theta`` rows keeps the paper's count.

    Raises :class:`InputError` when condition (29) fails (``k < 3``, or ``k > 3 + n_theta``
    without its rows) or the rows' rank leaves no split (``r < 3``, or no effort joints that
    fix the motion).
    """
    k = mode_unknowns(label)
    if k > 3 + n_joints and rows is not None:
        return _relaxed_partitions(n_joints, label, np.asarray(rows, dtype=float))
    if not 3 <= k <= 3 + n_joints:
        raise InputError(f"mode {label}: condition (29) expected 3 <= 2 n_R + n_S <= 3 + "
                         f"n_theta = {3 + n_joints}, got {k}")
    out = []
    for E in itertools.combinations(range(n_joints), k - 3):
        V = tuple(j for j in range(n_joints) if j not in E)
        out.append((V, tuple(E)))
    return out


def _relaxed_partitions(n_joints: int, label: str, rows: np.ndarray
                        ) -> list[tuple[tuple[int, ...], tuple[int, ...]]]:
    """:func:`control_partitions` of a force-indeterminate mode from the rank of its rows."""
    if rows.shape != (mode_unknowns(label), 3 + n_joints):
        raise InputError(f"mode {label}: expected its rows of shape ({mode_unknowns(label)}, "
                         f"{3 + n_joints}), got {rows.shape}")
    r = constraint_rank(rows)
    if not 3 <= r <= 3 + n_joints:
        raise InputError(f"mode {label}: expected its {len(rows)} kinematic rows to have rank "
                         f"between 3 and 3 + n_theta = {3 + n_joints} (condition 29 on the rank "
                         f"of a force-indeterminate mode), got rank {r}")
    out = []
    for E in itertools.combinations(range(n_joints), r - 3):
        if constraint_rank(rows[:, [0, 1, 2] + [3 + j for j in E]]) == r:
            out.append((tuple(j for j in range(n_joints) if j not in E), tuple(E)))
    if not out:
        raise InputError(f"mode {label}: expected {r - 3} effort-controlled joint(s) whose "
                         f"rates the contact rows fix together with the workpiece's twist "
                         f"(rank {r}), got no such choice of joints")
    return out


def joint_inputs(hand: Hand, V: tuple[int, ...], rates: Any) -> list[dict[str, float]]:
    """Per joint ``{"velocity": rate}`` for ``V`` (rates in order) and ``{"effort": 0}`` else."""
    r = dict(zip(V, (float(x) for x in rates)))
    return [{"velocity": r[j]} if j in r else {"effort": 0.0} for j in range(hand.n_joints)]


def predicted_modes(hand: Hand, q: Any, V: tuple[int, ...], rates: Any, tau: Any,
                    mus: Any) -> tuple[str, ...]:
    """The modes the planner finds feasible (eqs. 13-32,
    :func:`planner.predict.feasibility.feasible_modes`) for ``hand`` at configuration ``q
    (3 + n_theta,)`` with the joints ``V`` at ``rates`` and the others at the efforts ``tau
    (n_theta - |V|,)``, at any friction of ``mus`` (each one coefficient or ``(n_c,)``): their
    union, sorted."""
    system = hand.system(q, 0.0, joint_inputs(hand, tuple(V), rates))
    inputs = np.array(system.joint_inputs)
    inputs[[j for j in range(hand.n_joints) if j not in V]] = np.asarray(tau, dtype=float)
    system = system.with_joint_inputs(inputs)
    labels: set[str] = set()
    for mu in mus:
        labels.update(feasible_modes(system, mu).labels)
    return tuple(sorted(labels))


@dataclass(frozen=True, eq=False)
class Guaranteed:
    """The guaranteed efforts at one waypoint for one partition: ``region`` (the polytope
    ``A tau <= b``, its Chebyshev centre and radius ``margin``; empty: ``margin <= 0``) and,
    with one effort joint, the whole ``guarantee`` (its pieces and every mode's band)."""

    region: TorqueRegion
    guarantee: Guarantee | None = None

    @property
    def empty(self) -> bool:
        return self.region.empty

    def reason(self) -> str:
        """Why it is empty (the region's diagnosis)."""
        return str(self.region.diagnosis.get("reason", "empty region"))


def guaranteed_at(hand: Hand, q: np.ndarray, V: tuple[int, ...], rates: np.ndarray, claim: str,
                  mu: Any, model: str) -> Guaranteed:
    """The guaranteed efforts of ``claim`` at configuration ``q`` with the joints ``V`` at
    ``rates`` (module docstring).  Raises :class:`DegenerateError` from the stages."""
    joints = joint_inputs(hand, V, rates)
    system = hand.system(q, 0.0, joints)
    loads = hand.load_vertices(q)  # the uncertain mass and centre of mass (None: nominal)
    box = offset_box(hand, q, joints)  # the box of contact positions (None: none)
    if box is not None and len(system.effort_joints) != 1:
        raise DegenerateError(f"contact offsets: guaranteed with one effort-controlled joint, "
                              f"got {len(system.effort_joints)} (joints {V} velocity-controlled)")
    if len(system.effort_joints) == 1:
        g = guarantee(system, claim, mu, model=model, loads=loads, box=box)
        if g.claim_band is None:
            E = tuple(int(j) for j in system.effort_joints)
            return Guaranteed(empty_region(g.claim, 1, E, {
                "reason": f"{g.claim} is not kinematically admissible"}), g)
        return Guaranteed(_over_loads(band_region(system, g, g.best()), loads, box is not None),
                          g)
    return Guaranteed(_over_loads(torque_region(system, claim, mu, model=model, loads=loads),
                                  loads))


def _over_loads(region: TorqueRegion, loads: Any, positions: bool = False) -> TorqueRegion:
    """An empty region's reason names the mass / centre-of-mass set (or, with ``positions``,
    the box of contact positions) when there is one."""
    if (loads is None and not positions) or not region.empty or "reason" not in region.diagnosis:
        return region
    what = ("the box of contact positions" if positions
            else "the workpiece's mass and centre-of-mass set")
    reason = f"{region.diagnosis['reason']} (with {what})"
    return replace(region, diagnosis={**region.diagnosis, "reason": reason})


def choose_pieces(gs: list[Guaranteed]) -> list[Interval]:
    """``p = 1``: the band piece each waypoint uses: the widest piece that overlaps the previous
    waypoint's, else the widest (infinite first); EMPTY where there is none."""
    out: list[Interval] = []
    prev: Interval | None = None
    for gd in gs:
        g = gd.guarantee
        if g is None or not g.pieces:
            prev = EMPTY
        elif prev is not None and not prev.empty and (overlap := [
                p for p in g.pieces if p.lower <= prev.upper and p.upper >= prev.lower]):
            prev = max(overlap, key=lambda p: p.upper - p.lower)
        else:
            prev = g.best()
        out.append(prev)
    return out


def relative_margin(gd: Guaranteed) -> float:
    """How far the command is from the guaranteed set's edges relative to its size: the
    region's radius over its centre's norm (with one effort joint: half the widest piece's
    width over its middle's magnitude; a one-sided piece's radius is the step in from its finite
    end, :func:`planner.plan.polytope.band_region`); the radius itself (a normalised Coulomb
    slack) without effort joints; 1 for an unbounded radius.  The partition with the largest
    worst value is used."""
    reg = gd.region
    if not math.isfinite(reg.margin):
        return 1.0
    if not len(reg.effort_joints):
        return reg.margin
    return reg.margin / max(float(np.linalg.norm(reg.centre)), 1e-300)
