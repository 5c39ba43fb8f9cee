"""Offline planner for a hand segment: trajectory, control partition, torque bounds, commands.

Section 5.2 in code.  For a hand file (``planner.model.hand``) and its ``segment`` section:

1. integrate the quasistatic segment of the desired mode
   (:func:`planner.plan.trajectory.integrate_segment`) and resample it at evenly spaced waypoints;
2. choose the control partition (Section 3.2): each joint in turn is velocity-controlled and the
   others effort-controlled; a partition is usable when, at every waypoint, the desired mode is
   kinematically admissible and determinate (conditions 30-31), ``Q_AI`` is non-singular over the
   friction interval (32) and a torque band that guarantees the mode and excludes every rival
   exists (eq. 28, :func:`planner.plan.bounds.guarantee`); among usable partitions the one with the
   largest worst-case relative margin is taken;
3. pick the effort-controlled joint's torque per waypoint (``policy``): ``midband`` (middle of the
   band over each hold interval), ``constant`` (one torque inside every waypoint's band), or the
   negative control ``rival:FAMILY`` (torque inside the rival's own band, where it has one, while
   the plan still claims the desired mode -- validation must reject such a plan).

Plans record the band curves at the interval's ends and over the interval (Figures 10-13) in
``plan.extra["curves"]``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.files.hand_file import load_hand
from planner.model.hand import Hand
from planner.model.validation import friction_interval, validation_frictions
from planner.plan.bounds import mode_bands
from planner.plan.guarantee import Guarantee, guarantee
from planner.plan.intervals import EMPTY, Interval, subtract
from planner.plan.plan_file import Plan, Waypoint
from planner.plan.trajectory import Segment, integrate_segment

POLICIES = ("midband", "constant")


def _hand_path(path: str | os.PathLike[str]) -> Path:
    return Path(path)  # existence and kind are checked by the one JSON reader (load_hand)


@dataclass(frozen=True, eq=False)
class PartitionReport:
    """How a control partition fared: ``velocity_joint``, ``usable``, ``reason`` when not,
    ``worst_relative_margin`` over the waypoints, the per-waypoint :class:`Guarantee`."""

    velocity_joint: int
    usable: bool
    reason: str
    worst_relative_margin: float
    guarantees: tuple[Guarantee, ...]


def _joints(n: int, vel: int, rates: float) -> list[dict[str, float]]:
    return [{"velocity": rates} if k == vel else {"effort": 0.0} for k in range(n)]


def _command_in(piece: Interval, scale: float) -> float:
    lo, hi = piece.lower, piece.upper
    if math.isfinite(lo) and math.isfinite(hi):
        return 0.5 * (lo + hi)
    if math.isfinite(lo):
        return lo + max(abs(lo), scale)
    if math.isfinite(hi):
        return hi - max(abs(hi), scale)
    return 0.0


def _best_piece(g: Guarantee, prev: Interval | None) -> Interval:
    if not g.pieces:
        return EMPTY
    if prev is not None and not prev.empty:
        overlap = [p for p in g.pieces if p.lower <= prev.upper and p.upper >= prev.lower]
        if overlap:
            return max(overlap, key=lambda p: p.upper - p.lower)
    return g.best()


def _intersect(a: Interval, b: Interval) -> Interval:
    lo, hi = max(a.lower, b.lower), min(a.upper, b.upper)
    return Interval(lo, hi) if lo <= hi else EMPTY


def evaluate_partition(
    hand: Hand, seg: Segment, vel: int, mu: Any, model: str,
) -> PartitionReport:
    """Guarantees along ``seg`` with joint ``vel`` velocity-controlled (Section 3.2)."""
    gs: list[Guarantee] = []
    worst = math.inf
    for k in range(len(seg.t)):
        rate = float(seg.thetadot[k, vel])
        if abs(rate) <= 1e-12 * max(1.0, abs(seg.speed)):
            return PartitionReport(vel, False, f"joint {vel} does not move at t = {seg.t[k]:.3g} s",
                                   -math.inf, tuple(gs))
        system = hand.system(seg.q[k], 0.0, _joints(hand.n_joints, vel, rate))
        try:
            g = guarantee(system, seg.mode, mu, model=model)
        except DegenerateError as exc:
            return PartitionReport(vel, False, str(exc), -math.inf, tuple(gs))
        gs.append(g)
        if g.claim_band is None:
            return PartitionReport(vel, False, f"{seg.mode} not admissible at t = {seg.t[k]:.3g} s",
                                   -math.inf, tuple(gs))
        piece = g.best()
        if piece.empty:
            return PartitionReport(vel, False, f"no guaranteed torque at t = {seg.t[k]:.3g} s",
                                   -math.inf, tuple(gs))
        width = piece.upper - piece.lower
        if math.isfinite(width):
            mid = 0.5 * (piece.lower + piece.upper)
            worst = min(worst, 0.5 * width / max(abs(mid), 1e-300))
        else:
            worst = min(worst, 1.0)
    return PartitionReport(vel, True, "", worst, tuple(gs))


def plan_hand(
    scenario: str | os.PathLike[str],
    *,
    mu: Any = None,
    model: str = "common",
    policy: str = "midband",
    control: str | int = "auto",
    waypoints: int | None = None,
    validate_mu: Any = None,
) -> Plan:
    """Plan the hand file's segment (Section 5.2): see the module docstring.

    ``mu``: friction interval (``(lo, hi)``, per-contact list, or a number); defaults to the file's
    ``mu.interval``.  ``control``: ``"auto"`` or the index of the velocity-controlled joint.
    Raises :class:`planner.errors.DegenerateError` when no partition can guarantee the mode.
    """
    if policy not in POLICIES and not (policy.startswith("rival:") and len(policy) > 6):
        raise InputError(f"policy: expected one of {POLICIES} or 'rival:MODE', got {policy!r}")
    path = _hand_path(scenario)
    hand, q0, data = load_hand(path)
    seg_spec = data.get("segment")
    if not isinstance(seg_spec, dict):
        raise InputError(f"{path}: expected a 'segment' section to plan, got {seg_spec!r}")
    mu_spec = data.get("mu", {})
    if mu is None:
        mu = tuple(mu_spec.get("interval", (0.0, 0.0)))
    listed_validate = mu_spec.get("validate", []) if validate_mu is None else validate_mu
    seg_spec = dict(seg_spec)
    for key in ("drive", "speed"):  # one driven joint may be written as a one-element list
        if isinstance(seg_spec.get(key), list) and len(seg_spec[key]) == 1:
            seg_spec[key] = seg_spec[key][0]
    if hand.n_joints != 2 or isinstance(seg_spec.get("drive"), list):
        raise InputError(
            f"{path.name}: plan files (qsplan-plan version 1) hold one velocity- and one "
            "effort-controlled joint, expected a hand with 2 joints and one driven joint, got "
            f"{hand.n_joints} joints and drive {seg_spec.get('drive')!r}; plan it with "
            "planner.plan.region_planner.plan_regions (docs/two-finger-task.md, 'Any hand')"
        )
    drive = int(seg_spec.get("drive", 0))
    speed = float(seg_spec.get("speed", 0.01))
    mode = str(seg_spec.get("mode", "4S"))
    n_wp = int(waypoints or seg_spec.get("waypoints", 41))
    if n_wp < 2:
        raise InputError(f"waypoints: expected >= 2, got {n_wp}")
    seg = integrate_segment(hand, q0, drive=drive, speed=speed, mode=mode,
                            max_time=float(seg_spec.get("max_time", 60.0)),
                            steps=int(seg_spec.get("steps", 200)))
    seg = seg.resample(hand, n_wp)
    # Control partition (Section 3.2).
    if control == "auto":
        reports = [evaluate_partition(hand, seg, v, mu, model) for v in range(hand.n_joints)]
    else:
        v = int(control)
        if not 0 <= v < hand.n_joints:
            raise InputError(
                f"control: expected 'auto' or a joint index < {hand.n_joints}, got {v}"
            )
        reports = [evaluate_partition(hand, seg, v, mu, model)]
    usable = [r for r in reports if r.usable]
    if not usable:
        why = "; ".join(
            f"joint {r.velocity_joint} velocity-controlled: {r.reason}" for r in reports
        )
        raise DegenerateError(f"no control partition guarantees {seg.mode}: {why}")
    best = max(usable, key=lambda r: r.worst_relative_margin)
    vel = best.velocity_joint
    eff = next(k for k in range(hand.n_joints) if k != vel)
    gs = best.guarantees
    pieces: list[Interval] = []
    prev = None
    for g in gs:
        prev = _best_piece(g, prev)
        pieces.append(prev)
    finite_w = [p.upper - p.lower for p in pieces if math.isfinite(p.upper - p.lower)]
    scale = float(np.median(finite_w)) if finite_w else 1e-3
    # Hold intervals: the command of waypoint k is held until k+1, so it must sit in both bands.
    hold = [_intersect(pieces[k], pieces[min(k + 1, len(pieces) - 1)]) for k in range(len(pieces))]
    hold = [h if not h.empty else p for h, p in zip(hold, pieces)]
    mu_lo, mu_hi = friction_interval(mu, hand.n_contacts)
    at_lo, at_hi = _bands_at_ends(hand, seg, vel, mu_lo, mu_hi)
    taus, predicted = _choose(policy, hold, gs, scale, at_hi)
    wps = []
    for k in range(len(seg.t)):
        tau = taus[k]
        band = hold[k]
        wps.append(Waypoint(
            t=float(seg.t[k]),
            pose=tuple(float(x) for x in seg.q[k, :3]),  # type: ignore[arg-type]
            angles=tuple(float(x) for x in seg.q[k, 3:]),
            velocity_command=float(seg.thetadot[k, vel]),
            torque_command=float(tau),
            band=(band.lower, band.upper),
            margin=band.margin(tau),
            predicted=predicted[k],
            rivals=gs[k].rivals,
        ))
    names = hand.joint_names()
    control_t = tuple("velocity" if k == vel else "effort" for k in range(hand.n_joints))
    curves = _curves(seg, gs, at_lo, at_hi, mu_lo, mu_hi)
    return Plan(
        hand=data,
        claim=seg.mode,
        control=control_t,
        mu_model=model,
        mu_intervals=tuple((float(a), float(b)) for a, b in zip(mu_lo, mu_hi)),
        validate_mu=validation_frictions(listed_validate, mu_lo, mu_hi),
        policy=policy,
        event={"kind": seg.event.kind, "detail": seg.event.detail, "t": seg.event.t},
        waypoints=tuple(wps),
        exact=all(g.exact for g in gs),
        notes=(f"joint {vel} ({names[vel]}) velocity-controlled, joint {eff} "
               f"({names[eff]}) effort-controlled; partitions: "
               + "; ".join(f"joint {r.velocity_joint} velocity: "
                           + ("usable, worst relative margin "
                              f"{r.worst_relative_margin:.3g}" if r.usable else r.reason)
                           for r in reports)),
        extra={"source": path.name, "curves": curves},
    )



BandsAt = list[dict[str, tuple[str, Interval]]]


def _bands_at_ends(hand: Hand, seg: Segment, vel: int, mu_lo: np.ndarray, mu_hi: np.ndarray
                   ) -> tuple[BandsAt, BandsAt]:
    """Per waypoint, every mode's interval at the friction interval's two ends:
    ``(at_lo, at_hi)``, each a list of ``{label: (family, Interval)}``."""
    at_lo: BandsAt = []
    at_hi: BandsAt = []
    for k in range(len(seg.t)):
        system = hand.system(seg.q[k], 0.0,
                             _joints(hand.n_joints, vel, float(seg.thetadot[k, vel])))
        for mu_v, out in ((mu_lo, at_lo), (mu_hi, at_hi)):
            bands = mode_bands(system, np.stack([mu_v, mu_v], 1))
            out.append({b.label: (b.mode.family, b.possible) for b in bands})
    return at_lo, at_hi


def _choose(
    policy: str, hold: list[Interval], gs: tuple[Guarantee, ...], scale: float,
    at_hi: list[dict[str, tuple[str, Interval]]],
) -> tuple[list[float], list[tuple[str, ...]]]:
    n = len(hold)
    if policy == "midband":
        taus = [_command_in(h, scale) for h in hold]
    elif policy == "constant":
        common = hold[0]
        for h in hold[1:]:
            common = _intersect(common, h)
        if common.empty:
            raise DegenerateError(
                "policy 'constant': the guaranteed bands of the waypoints do not overlap; "
                "use 'midband'"
            )
        taus = [_command_in(common, scale)] * n
    elif policy.startswith("rival:"):
        fam = policy.split(":", 1)[1]
        taus = [_command_in(h, scale) for h in hold]
        # The rival: the named label, or the first mode of the named family that is possible
        # (at the upper friction end) along the segment; it is kept for the whole segment.
        target = None
        for k in range(n):
            for lab, (f, iv) in at_hi[k].items():
                if (lab == fam or f == fam) and lab != gs[k].claim and not iv.empty:
                    target = lab
                    break
            if target is not None:
                break
        if target is None:
            raise DegenerateError(f"policy {policy!r}: no mode {fam!r} is possible on this segment")
        for k in range(n):
            own = at_hi[k].get(gs[k].claim, ("", EMPTY))[1]
            iv = at_hi[k].get(target, ("", EMPTY))[1]
            only = subtract(iv, [own]) if not iv.empty else []
            if only:
                taus[k] = _command_in(max(only, key=lambda x: x.upper - x.lower), scale)
    else:
        raise InputError(f"policy: expected one of {POLICIES} or 'rival:FAMILY', got {policy!r}")
    predicted: list[tuple[str, ...]] = []
    for k in range(n):
        g = gs[k]
        if any(p.contains(taus[k]) for p in g.pieces):
            predicted.append((g.claim,))
        else:
            predicted.append(tuple(b.label for b in g.bands if b.possible.contains(taus[k])))
    return taus, predicted


def _curves(seg: Segment, gs: tuple[Guarantee, ...], at_lo: list[dict], at_hi: list[dict],
            mu_lo: np.ndarray, mu_hi: np.ndarray) -> dict[str, Any]:
    """Band curves for Figures 10-13: per mode, interval at ``mu_lo``, at ``mu_hi``, guaranteed
    and possible over the interval (None = empty; None inside a pair = unbounded)."""
    def enc(iv: Interval) -> list[float | None] | None:
        return None if iv.empty else iv.to_list()

    n = len(seg.t)
    modes: dict[str, dict[str, Any]] = {}
    for k in range(n):
        for b in gs[k].bands:
            m = modes.setdefault(b.label, {"family": b.mode.family, "at_lo": [None] * n,
                                           "at_hi": [None] * n, "guaranteed": [None] * n,
                                           "possible": [None] * n})
            m["at_lo"][k] = enc(at_lo[k].get(b.label, ("", EMPTY))[1])
            m["at_hi"][k] = enc(at_hi[k].get(b.label, ("", EMPTY))[1])
            m["guaranteed"][k] = enc(b.guaranteed)
            m["possible"][k] = enc(b.possible)
    travel = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(seg.q[:, :2], axis=0),
                                                              axis=1))])
    return {"t": [float(x) for x in seg.t], "travel": [float(x) for x in travel],
            "mu_lo": [float(x) for x in mu_lo], "mu_hi": [float(x) for x in mu_hi],
            "modes": modes}
