"""The commands of a planned segment: what each joint is told at each waypoint (Section 5.2).

The command of waypoint ``k`` is held until waypoint ``k + 1`` (the *hold interval*).

* **Velocity-controlled joints** (:func:`velocity_commands`): a driven joint at its constant
  rate; any other at the rate that takes it from its planned coordinate at waypoint ``k`` to
  the one at ``k + 1`` over the hold interval (the mean rate), so a held rate reaches every
  waypoint on the planned path (the rate at ``t_k`` held instead leaves the joint behind or
  ahead by ``1/2 dt^2 d(rate)/dt`` per interval, which adds up: docs/planning.md, "Waypoint
  spacing"); the last waypoint keeps the rate there.
* **Effort-controlled joints** (:func:`effort_commands`), by ``policy``:
  ``midband`` -- the centre of the set guaranteed at both ends of the hold interval (the middle
  of the hold band with one effort joint, Figure 13; the Chebyshev centre of the intersection
  of both regions with several; the waypoint's own set alone when the two do not meet);
  ``constant`` -- one command inside every waypoint's set; ``rival:MODE`` (one effort joint; a
  negative control) -- an effort inside the named rival's band where it has one
  (:func:`planner.plan.curves.bands_at_ends`), while the plan still claims its mode.

Each waypoint also gets its ``bands`` (per effort joint, the range of its effort with the
others held that keeps the guarantee at both ends of the hold interval), its ``margin`` (the
radius of the ball of commands that does: the smallest normalised slack of the rows of both
ends' sets at the command; negative when the command is outside one), the modes
``predicted`` at the command and the ``rivals``.  Units: rates in rad/s or m/s, efforts in N m
or N.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.hand import Hand
from planner.plan.curves import BandsAt
from planner.plan.intervals import EMPTY, Interval, subtract
from planner.plan.model import Waypoint
from planner.plan.partition import Guaranteed, choose_pieces, joint_inputs
from planner.plan.polytope import TorqueRegion, band_region, chebyshev_centre
from planner.plan.trajectory import Trajectory
from planner.predict.feasibility import feasible_modes

POLICIES = ("midband", "constant")


def check_policy(policy: str) -> None:
    """Raise :class:`InputError` for a policy other than :data:`POLICIES` or ``rival:MODE``."""
    if policy not in POLICIES and not (policy.startswith("rival:") and len(policy) > 6):
        raise InputError(f"policy: expected one of {POLICIES} or 'rival:MODE', got {policy!r}")


def velocity_commands(states: Trajectory, V: tuple[int, ...]) -> np.ndarray:
    """``(n, |V|)`` the held rates of the velocity-controlled joints ``V`` (module docstring);
    ``states`` the trajectory at the waypoints."""
    n = len(states.t)
    out = np.array(states.thetadot[:, list(V)], dtype=float).reshape(n, len(V))
    rate = dict(zip(states.drives, states.speeds))
    for i, j in enumerate(V):
        if j in rate:
            out[:, i] = rate[j]
        elif n > 1:
            out[:-1, i] = np.diff(states.q[:, 3 + j]) / np.diff(states.t)
    return out


def effort_commands(hand: Hand, states: Trajectory, V: tuple[int, ...], gs: Sequence[Guaranteed],
                    policy: str, mu_box: tuple[np.ndarray, np.ndarray],
                    at_hi: BandsAt | None = None
                    ) -> tuple[list[Waypoint], tuple[TorqueRegion, ...]]:
    """The waypoints of one partition (module docstring) and the region each uses.  ``gs``
    the guaranteed set at each waypoint (:func:`planner.plan.partition.guaranteed_at`);
    ``mu_box`` the friction box ``(lo, hi)`` per contact; ``at_hi``: every mode's band at the
    upper friction end (the ``rival:`` policy)."""
    check_policy(policy)
    vel = velocity_commands(states, V)
    if gs and gs[0].guarantee is not None:
        rows = _one_effort(hand, states, V, vel, gs, policy, at_hi)
    elif policy.startswith("rival:"):
        raise InputError(f"policy {policy!r}: expected a segment with one effort-controlled "
                         f"joint, got {len(gs[0].region.effort_joints) if gs else 0}")
    else:
        rows = _any_effort(hand, states, V, vel, gs, policy, mu_box)
    wps = [Waypoint(t=float(states.t[k]), pose=(float(states.q[k, 0]), float(states.q[k, 1]),
                                                float(states.q[k, 2])),
                    angles=tuple(float(x) for x in states.q[k, 3:]),
                    velocity_commands=tuple(float(x) for x in vel[k]),
                    torque_commands=tau, bands=bands, margin=margin, predicted=pred,
                    rivals=rivals)
           for k, (tau, bands, margin, pred, rivals, _) in enumerate(rows)]
    return wps, tuple(r[5] for r in rows)


Row = tuple[tuple[float, ...], tuple[tuple[float, float], ...], float, tuple[str, ...],
            tuple[str, ...], TorqueRegion]


def _one_effort(hand: Hand, states: Trajectory, V: tuple[int, ...], vel: np.ndarray,
                gs: Sequence[Guaranteed], policy: str, at_hi: BandsAt | None) -> list[Row]:
    """One effort joint: interval arithmetic on the band pieces (Figure 13)."""
    n = len(gs)
    pieces = choose_pieces(list(gs))
    hold = [_intersect(pieces[k], pieces[min(k + 1, n - 1)]) for k in range(n)]
    hold = [h if not h.empty else p for h, p in zip(hold, pieces)]
    systems = [hand.system(states.q[k], 0.0, joint_inputs(hand, V, vel[k])) for k in range(n)]
    gk = [gd.guarantee for gd in gs]
    if policy == "midband":
        taus = [_centre(systems[k], gk[k], hold[k]) for k in range(n)]
    elif policy == "constant":
        common = hold[0]
        for h in hold[1:]:
            common = _intersect(common, h)
        if common.empty:
            raise DegenerateError("policy 'constant': the guaranteed bands of the waypoints do "
                                  "not overlap; use 'midband'")
        taus = [_centre(systems[0], gk[0], common)] * n
    else:
        taus = _rival(policy, hold, gk, systems, at_hi)
    rows: list[Row] = []
    for k in range(n):
        g, tau = gk[k], taus[k]
        assert g is not None  # one effort joint: every waypoint has its band
        margin = min(pieces[k].margin(tau), pieces[min(k + 1, n - 1)].margin(tau))
        if any(p.contains(tau) for p in g.pieces):
            pred: tuple[str, ...] = (g.claim,)
        else:
            pred = tuple(b.label for b in g.bands if b.possible.contains(tau))
        rows.append(((float(tau),), ((hold[k].lower, hold[k].upper),), float(margin), pred,
                     g.rivals, band_region(systems[k], g, pieces[k])))
    return rows


def _centre(system: Any, g: Any, piece: Interval) -> float:
    """The command inside ``piece``: its middle, or a step in from a one-sided piece's end
    (:func:`planner.plan.polytope.band_region`)."""
    return float(band_region(system, g, piece).centre[0])


def _intersect(a: Interval, b: Interval) -> Interval:
    lo, hi = max(a.lower, b.lower), min(a.upper, b.upper)
    return Interval(lo, hi) if lo <= hi else EMPTY


def _rival(policy: str, hold: list[Interval], gk: list[Any], systems: list[Any],
           at_hi: BandsAt | None) -> list[float]:
    """``rival:FAMILY`` or ``rival:LABEL``: inside the rival's own band (at the upper friction
    end, where it is possible and the claim is not), else the hold band's centre.  The rival is
    the named label, or the first mode of the named family possible along the segment."""
    if at_hi is None:
        raise InputError("policy rival: expected the bands at the upper friction end")
    fam = policy.split(":", 1)[1]
    taus = [_centre(s, g, h) for s, g, h in zip(systems, gk, hold)]
    target = next((lab for k in range(len(hold)) for lab, (f, iv) in at_hi[k].items()
                   if (lab == fam or f == fam) and lab != gk[k].claim and not iv.empty), None)
    if target is None:
        raise DegenerateError(f"policy {policy!r}: no mode {fam!r} is possible on this segment")
    for k in range(len(hold)):
        own = at_hi[k].get(gk[k].claim, ("", EMPTY))[1]
        iv = at_hi[k].get(target, ("", EMPTY))[1]
        only = subtract(iv, [own]) if not iv.empty else []
        if only:
            taus[k] = _centre(systems[k], gk[k], max(only, key=lambda x: x.upper - x.lower))
    return taus


def _any_effort(hand: Hand, states: Trajectory, V: tuple[int, ...], vel: np.ndarray,
                gs: Sequence[Guaranteed], policy: str,
                mu_box: tuple[np.ndarray, np.ndarray]) -> list[Row]:
    """Any number of effort joints: Chebyshev centres of the polytopes."""
    n = len(gs)
    regs = [gd.region for gd in gs]
    if policy == "constant":
        c, r = chebyshev_centre(np.vstack([g.A for g in regs]), np.concatenate([g.b for g in regs]))
        if not r > 0:
            raise DegenerateError("policy 'constant': the guaranteed regions of the waypoints "
                                  "do not overlap; use 'midband'")
        taus = [np.asarray(c, dtype=float)] * n
    else:
        taus = []
        for k in range(n):
            nxt = regs[min(k + 1, n - 1)]
            c, r = chebyshev_centre(np.vstack([regs[k].A, nxt.A]),
                                    np.concatenate([regs[k].b, nxt.b]))
            taus.append(np.asarray(c if r > 0 else regs[k].centre, dtype=float))
    rows: list[Row] = []
    for k in range(n):
        reg, nxt, tau = regs[k], regs[min(k + 1, n - 1)], taus[k]
        both_A, both_b = np.vstack([reg.A, nxt.A]), np.concatenate([reg.b, nxt.b])
        inside = _slack(reg.A, reg.b, tau) >= 0
        hold_A, hold_b = (both_A, both_b) if _slack(nxt.A, nxt.b, tau) >= 0 and inside else (
            reg.A, reg.b)
        pred = (reg.claim,) if inside else _predicted_at(hand, states.q[k], V, vel[k], reg,
                                                        tau, mu_box)
        rows.append((tuple(float(x) for x in tau), axis_bands(hold_A, hold_b, tau),
                     _slack(both_A, both_b, tau), pred, reg.rivals, reg))
    return rows


def _slack(A: np.ndarray, b: np.ndarray, tau: np.ndarray) -> float:
    """Smallest normalised slack ``(b - A tau) / |A_i|`` (``p = 0``: the smallest ``b``, the
    normalised Coulomb slacks); ``inf`` without rows."""
    if not len(b):
        return math.inf
    if A.shape[1] == 0:
        return float(np.min(b))
    norms = np.linalg.norm(A, axis=1)
    keep = norms > 0
    s = (b[keep] - A[keep] @ tau) / norms[keep]
    flat = b[~keep]
    return float(min(np.min(s) if s.size else math.inf, np.min(flat) if flat.size else math.inf))


def axis_bands(A: np.ndarray, b: np.ndarray, tau: np.ndarray) -> tuple[tuple[float, float], ...]:
    """Per effort joint ``j``, the range of ``tau_j`` inside ``{A x <= b}`` with the other
    efforts held at ``tau`` (the polytope's slice along axis ``j`` through the command)."""
    out = []
    slack = b - A @ tau if len(b) else np.zeros(0)
    for j in range(A.shape[1]):
        a = A[:, j]
        with np.errstate(divide="ignore", invalid="ignore"):
            step = slack / a
        hi = float(np.min(step[a > 0])) if np.any(a > 0) else math.inf
        lo = float(np.max(step[a < 0])) if np.any(a < 0) else -math.inf
        out.append((float(tau[j]) + lo, float(tau[j]) + hi))
    return tuple(out)


def _predicted_at(hand: Hand, q: np.ndarray, V: tuple[int, ...], rates: np.ndarray,
                  reg: TorqueRegion, tau: np.ndarray, mu_box: tuple[np.ndarray, np.ndarray]
                  ) -> tuple[str, ...]:
    """The modes the planner finds feasible at command ``tau`` at the corners of the friction
    box ``mu_box`` (for a command outside its own region)."""
    from planner.plan.bounds import box_points

    system = hand.system(q, 0.0, joint_inputs(hand, V, rates))
    inputs = np.array(system.joint_inputs)
    inputs[list(reg.effort_joints)] = tau
    system = system.with_joint_inputs(inputs)
    labels: set[str] = set()
    for mu in box_points(mu_box[0], mu_box[1], 2)[0]:
        labels.update(feasible_modes(system, mu).labels)
    return tuple(sorted(labels))
