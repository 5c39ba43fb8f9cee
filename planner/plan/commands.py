"""The commands of a planned segment: what each joint is told at each waypoint (Section 5.2).

The command of waypoint ``k`` is held until waypoint ``k + 1`` (the *hold interval*).

* **Velocity-controlled joints** (:func:`velocity_commands`): a driven joint at its constant
  rate; any other at the rate that takes it from its planned coordinate at waypoint ``k`` to
  the one at ``k + 1`` over the hold interval (the mean rate), so a held rate reaches every
  waypoint on the planned path (the rate at ``t_k`` held instead leaves the joint behind or
  ahead by ``1/2 dt^2 d(rate)/dt`` per interval, which adds up: docs/planning.md, "Waypoint
  spacing"); the last waypoint keeps the rate there.
* **Effort-controlled joints** (:func:`effort_commands`), by ``policy``
  (:mod:`planner.plan.policies`: the hold sets, the required margin and the smooth policy's
  bound): ``smooth`` (the default) -- the commands inside every hold set, keeping the required
  margin, whose largest change between waypoints is the smallest possible; ``least-effort`` --
  the least squeeze that keeps the margin; ``max-margin`` or ``midband`` -- the centre of the set
  guaranteed at both ends of the hold interval (the middle of the hold band with one effort
  joint, Figure 13; the Chebyshev centre of the intersection of both regions with several; the
  waypoint's own set alone when the two do not meet); ``constant`` -- one command inside every
  waypoint's set; ``rival:MODE`` (one effort joint; a negative control) -- an effort inside the
  named rival's band where it has one (:func:`planner.plan.curves.bands_at_ends`), while the
  plan still claims its mode.  The joints' limits (:mod:`planner.files.hand_limits`) cut every
  set; a set they empty is a :class:`DegenerateError` naming the joint and the effort missing.

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
from dataclasses import replace
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.files.hand_limits import JointLimits
from planner.model.hand import Hand
from planner.plan.bounds import box_points
from planner.plan.curves import BandsAt
from planner.plan.intervals import EMPTY, Interval, subtract
from planner.plan.limits_words import effort_limit_words, speed_limit_words
from planner.plan.model import Waypoint
from planner.plan.partition import Guaranteed, choose_pieces, joint_inputs, predicted_modes
from planner.plan.policies import (
    HoldSet,
    change_report,
    hold_set,
    least_effort,
    parse_policy,
    smoothest,
)
from planner.plan.polytope import TorqueRegion, band_region, chebyshev_centre, torque_scale
from planner.plan.trajectory import Trajectory
from planner.plan.wording import effort_unit, joint_words


def check_policy(policy: str) -> None:
    """Raise :class:`InputError` for a policy other than those of
    :data:`planner.plan.policies.POLICIES`, ``least-effort:M`` or ``rival:MODE``."""
    parse_policy(policy)


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
                    at_hi: BandsAt | None = None, limits: JointLimits | None = None
                    ) -> tuple[list[Waypoint], tuple[TorqueRegion, ...], dict[str, object]]:
    """The waypoints of one partition (module docstring), the region each uses and the report
    of the command changes (:func:`planner.plan.policies.change_report`, a segment's
    ``extra["commands"]``).  ``gs`` the guaranteed set at each waypoint
    (:func:`planner.plan.partition.guaranteed_at`); ``mu_box`` the friction box ``(lo, hi)``
    per contact; ``at_hi``: every mode's band at the upper friction end (the ``rival:``
    policy); ``limits`` the joints' limits (default none).  Raises :class:`DegenerateError`
    when the limits leave a waypoint no guaranteed command (naming the joint and the effort
    missing) or a rate above a joint's speed limit."""
    check_policy(policy)
    limits = limits or JointLimits.none(hand.n_joints)
    vel = velocity_commands(states, V)
    _check_speeds(hand, states, V, vel, limits)
    if gs and gs[0].guarantee is not None:
        rows, holds = _one_effort(hand, states, V, vel, gs, policy, at_hi, limits)
    elif policy.startswith("rival:"):
        raise InputError(f"policy {policy!r}: expected a segment with one effort-controlled "
                         f"joint, got {len(gs[0].region.effort_joints) if gs else 0}")
    else:
        rows, holds = _any_effort(hand, states, V, vel, gs, policy, mu_box, limits)
    wps = [Waypoint(t=float(states.t[k]), pose=(float(states.q[k, 0]), float(states.q[k, 1]),
                                                float(states.q[k, 2])),
                    angles=tuple(float(x) for x in states.q[k, 3:]),
                    velocity_commands=tuple(float(x) for x in vel[k]),
                    torque_commands=tau, bands=bands, margin=margin, predicted=pred,
                    rivals=rivals)
           for k, (tau, bands, margin, pred, rivals, _) in enumerate(rows)]
    E = tuple(j for j in range(hand.n_joints) if j not in V)
    names, unit = [joint_words(hand, j) for j in E], effort_unit(hand, E)
    taus = np.array([r[0] for r in rows], dtype=float).reshape(len(rows), len(E))
    bound = None
    if E and not policy.startswith("rival:"):
        rates = np.array(limits.effort_rate)[list(E)]
        bound = smoothest(holds, rates, names, unit).bound
        _check_rates(taus, states.t, rates, names, unit, policy)
    report = change_report(taus, states.t, names, unit, policy, bound)
    return wps, tuple(r[5] for r in rows), report


Row = tuple[tuple[float, ...], tuple[tuple[float, float], ...], float, tuple[str, ...],
            tuple[str, ...], TorqueRegion]


def _check_speeds(hand: Hand, states: Trajectory, V: tuple[int, ...], vel: np.ndarray,
                  limits: JointLimits) -> None:
    """A velocity-controlled joint's held rate above its speed limit is a diagnosis."""
    for i, j in enumerate(V):
        top = limits.speed[j]
        over = np.flatnonzero(np.abs(vel[:, i]) > top * (1 + 1e-9))
        if over.size:
            k = int(over[0])
            raise DegenerateError(speed_limit_words(hand, j, float(vel[k, i]), top,
                                                    float(states.t[k])))


def _check_rates(taus: np.ndarray, t: np.ndarray, rates: np.ndarray, names: list[str],
                 unit: str, policy: str) -> None:
    """Commands of a policy other than ``smooth`` (which keeps them by construction) that
    change faster than a joint's effort-rate limit are a diagnosis."""
    if len(t) < 2:
        return
    step = np.abs(np.diff(taus, axis=0))
    allowed = np.diff(t)[:, None] * rates[None, :]
    scale = max(float(np.max(np.abs(taus))) if taus.size else 0.0, 1e-300)
    over = np.argwhere(step > allowed + 1e-7 * scale)
    if over.size:
        k, j = (int(x) for x in over[0])
        raise DegenerateError(
            f"policy {policy!r} changes the effort of {names[j]} by {step[k, j]:.4g} {unit} "
            f"between t = {t[k]:.4g} and {t[k + 1]:.4g} s, more than its effort-rate limit "
            f"({rates[j]:.4g} {unit}/s) allows ({allowed[k, j]:.4g} {unit}); the default "
            "policy 'smooth' keeps the limits where any commands can")


def _clip(g: Any, lo: float, hi: float) -> Any:
    """A one-effort guarantee with its pieces cut to the effort limits ``[lo, hi]``."""
    pieces = tuple(Interval(max(p.lower, lo), min(p.upper, hi)) for p in g.pieces)
    return replace(g, pieces=tuple(p for p in pieces if p.upper > p.lower))


def _one_effort(hand: Hand, states: Trajectory, V: tuple[int, ...], vel: np.ndarray,
                gs: Sequence[Guaranteed], policy: str, at_hi: BandsAt | None,
                limits: JointLimits) -> tuple[list[Row], list[HoldSet]]:
    """One effort joint: interval arithmetic on the band pieces (Figure 13)."""
    n = len(gs)
    E = tuple(j for j in range(hand.n_joints) if j not in V)
    (lim_lo,), (lim_hi,) = limits.effort_box(E)
    if math.isfinite(lim_lo) or math.isfinite(lim_hi):
        for k, gd in enumerate(gs):
            g = gd.guarantee
            assert g is not None  # one effort joint: every waypoint has its band
            if g.pieces and not _clip(g, lim_lo, lim_hi).pieces:
                raise DegenerateError(effort_limit_words(
                    hand, g.claim, float(states.t[k]), E[0], list(g.pieces), lim_lo, lim_hi))
        gs = [Guaranteed(gd.region, _clip(gd.guarantee, lim_lo, lim_hi)) for gd in gs]
    pieces = choose_pieces(list(gs))
    hold = [_intersect(pieces[k], pieces[min(k + 1, n - 1)]) for k in range(n)]
    hold = [h if not h.empty else p for h, p in zip(hold, pieces)]
    systems = [hand.system(states.q[k], 0.0, joint_inputs(hand, V, vel[k])) for k in range(n)]
    gk = [gd.guarantee for gd in gs]
    holds = [hold_set(np.array([[1.0], [-1.0]]), np.array([h.upper, -h.lower]),
                      torque_scale(systems[k], E), float(states.t[k]))
             for k, h in enumerate(hold)]
    name, margin_arg = parse_policy(policy)
    if name in ("midband", "max-margin"):
        taus = [_centre(systems[k], gk[k], hold[k]) for k in range(n)]
    elif name == "constant":
        common = hold[0]
        for h in hold[1:]:
            common = _intersect(common, h)
        if common.empty:
            raise DegenerateError("policy 'constant': the guaranteed bands of the waypoints do "
                                  "not overlap; use 'smooth'")
        taus = [_centre(systems[0], gk[0], common)] * n
    elif name in ("smooth", "least-effort"):
        taus = [float(x) for x in _chosen(name, margin_arg, holds, limits, E, hand)[:, 0]]
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
    return rows, holds


def _chosen(name: str, margin: float | None, holds: list[HoldSet], limits: JointLimits,
            E: tuple[int, ...], hand: Hand) -> np.ndarray:
    """``(n, p)`` the smooth or least-effort commands (:mod:`planner.plan.policies`)."""
    if not E:  # no effort joint: nothing to choose
        return np.zeros((len(holds), 0))
    if name == "least-effort":
        return np.array([least_effort(h, margin) for h in holds])
    return smoothest(holds, np.array(limits.effort_rate)[list(E)],
                     [joint_words(hand, j) for j in E], effort_unit(hand, E)).taus


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


def _limit_rows(E: tuple[int, ...], limits: JointLimits) -> tuple[np.ndarray, np.ndarray]:
    """``tau_j <= hi_j`` and ``-tau_j <= -lo_j`` for the effort joints' finite limits."""
    lo, hi = limits.effort_box(E)
    p = len(E)
    A = np.vstack([np.eye(p), -np.eye(p)])
    b = np.concatenate([hi, -lo])
    keep = np.isfinite(b)
    return A[keep], b[keep]


def _any_effort(hand: Hand, states: Trajectory, V: tuple[int, ...], vel: np.ndarray,
                gs: Sequence[Guaranteed], policy: str, mu_box: tuple[np.ndarray, np.ndarray],
                limits: JointLimits) -> tuple[list[Row], list[HoldSet]]:
    """Any number of effort joints: Chebyshev centres of the polytopes (cut by the limits)."""
    n = len(gs)
    E = tuple(j for j in range(hand.n_joints) if j not in V)
    LA, Lb = _limit_rows(E, limits)
    regs = [gd.region for gd in gs]
    cut = [(np.vstack([g.A, LA]), np.concatenate([g.b, Lb])) for g in regs]
    for k, (A, b) in enumerate(cut):
        if len(Lb) and not chebyshev_centre(A, b)[1] > 0:
            raise DegenerateError(effort_limit_words(hand, regs[k].claim, float(states.t[k]),
                                                     E, regs[k], *limits.effort_box(E)))
    holds = []
    for k in range(n):
        A2, b2 = (np.vstack([cut[k][0], cut[min(k + 1, n - 1)][0]]),
                  np.concatenate([cut[k][1], cut[min(k + 1, n - 1)][1]]))
        if not chebyshev_centre(A2, b2)[1] > 0:
            A2, b2 = cut[k]
        system = hand.system(states.q[k], 0.0, joint_inputs(hand, V, vel[k]))
        holds.append(hold_set(A2, b2, torque_scale(system, E), float(states.t[k])))
    name, margin_arg = parse_policy(policy)
    if name == "constant":
        c, r = chebyshev_centre(np.vstack([A for A, _ in cut]), np.concatenate([b for _, b in cut]))
        if not r > 0:
            raise DegenerateError("policy 'constant': the guaranteed regions of the waypoints "
                                  "do not overlap; use 'smooth'")
        taus = [np.asarray(c, dtype=float)] * n
    elif name in ("smooth", "least-effort"):
        taus = list(_chosen(name, margin_arg, holds, limits, E, hand))
    else:
        taus = []
        for k in range(n):
            c, r = chebyshev_centre(holds[k].A, holds[k].b)
            taus.append(np.asarray(c if r > 0 else regs[k].centre, dtype=float))
    rows: list[Row] = []
    for k in range(n):
        reg, nxt, tau = regs[k], regs[min(k + 1, n - 1)], taus[k]
        both_A, both_b = np.vstack([reg.A, nxt.A]), np.concatenate([reg.b, nxt.b])
        inside = _slack(reg.A, reg.b, tau) >= 0
        hold_A, hold_b = (both_A, both_b) if _slack(nxt.A, nxt.b, tau) >= 0 and inside else (
            reg.A, reg.b)
        # outside its own region, the modes at the corners of the friction box
        pred = (reg.claim,) if inside else predicted_modes(
            hand, states.q[k], V, vel[k], tau, box_points(mu_box[0], mu_box[1], 2)[0])
        rows.append((tuple(float(x) for x in tau), axis_bands(hold_A, hold_b, tau),
                     _slack(both_A, both_b, tau), pred, reg.rivals, reg))
    return rows, holds


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


