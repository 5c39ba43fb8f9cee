"""Diagnoses of joint limits that leave a segment no guaranteed command, in plain words: which
joint, what the guarantee needs from it and how much effort (or rate) it lacks
(:mod:`planner.files.hand_limits`; used by :mod:`planner.plan.commands`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.optimize import linprog

from planner.model.hand import Hand
from planner.plan.wording import effort_unit, joint_words


def _num(x: float) -> str:
    return f"{x:.4g}" if math.isfinite(x) else ("inf" if x > 0 else "-inf")


def _rng(lo: float, hi: float) -> str:
    return f"[{_num(lo)}, {_num(hi)}]"


def effort_limit_words(hand: Hand, claim: str, t: float, joints: int | Sequence[int],
                       need: Any, lo: Any, hi: Any) -> str:
    """Why the effort limits empty the guaranteed set at time ``t`` (s): ``joints`` one effort
    joint with ``need`` its guaranteed pieces (:class:`planner.plan.intervals.Interval` s) and
    ``lo, hi`` its limits, or several with ``need`` their region (``A tau <= b``) and ``lo, hi``
    ``(p,)``.  Names the joint whose limit is the shortest way out and the effort it lacks."""
    if isinstance(joints, (int, np.integer)):
        j, pieces = int(joints), list(need)
        unit = effort_unit(hand, (j,))
        lo_v, hi_v = float(np.ravel(lo)[0]), float(np.ravel(hi)[0])
        ends = [abs(x) for p in pieces for x in (p.lower, p.upper, lo_v, hi_v)
                if math.isfinite(x)]
        tiny = 1e-9 * max(ends, default=1.0)  # rounding of an end at zero effort

        def r(x: float) -> float:
            return 0.0 if abs(x) <= tiny else x

        gaps = [(lo_v - p.upper, p.upper, "at most") if p.upper < lo_v else
                (p.lower - hi_v, p.lower, "at least") for p in pieces]
        gap, end, word = min(gaps)
        return (f"the joint limits leave no guaranteed command: at t = {t:.4g} s {claim} needs "
                f"{joint_words(hand, j)} to exert an effort of {word} {r(end):.4g} {unit} (the "
                "efforts that guarantee it: "
                f"{', '.join(_rng(r(p.lower), r(p.upper)) for p in pieces)}), but its limits "
                f"are {_rng(lo_v, hi_v)} {unit}: {r(gap):.4g} {unit} missing")
    E = tuple(int(x) for x in joints)
    A, b = np.asarray(need.A, dtype=float), np.asarray(need.b, dtype=float)
    lo_a, hi_a = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    best = None
    for i in range(len(E)):
        got = _excess(A, b, lo_a, hi_a, i)
        if got is not None and (best is None or got[0] < best[0]):
            best = (got[0], got[1], i)
    if best is None:
        return (f"the joint limits leave no guaranteed command at t = {t:.4g} s: no single "
                f"joint's limit relaxed makes {claim} guaranteed (limits "
                + ", ".join(f"{joint_words(hand, j)} {_rng(lo_a[i], hi_a[i])}"
                            for i, j in enumerate(E)) + ")")
    gap, tau_i, i = best
    scale = max([abs(x) for x in (*lo_a, *hi_a) if math.isfinite(x)], default=1.0)
    tau_i = 0.0 if abs(tau_i) <= 1e-9 * scale else tau_i  # rounding of a face at zero effort
    j = E[i]
    unit = effort_unit(hand, (j,))
    word = "at least" if tau_i > hi_a[i] else "at most"
    return (f"the joint limits leave no guaranteed command: at t = {t:.4g} s {claim} needs "
            f"{joint_words(hand, j)} to exert an effort of {word} {tau_i:.4g} {unit} (the other "
            f"effort joints within their limits), but its limits are "
            f"{_rng(lo_a[i], hi_a[i])} {unit}: {gap:.4g} {unit} missing")


def _excess(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray, i: int
            ) -> tuple[float, float] | None:
    """``(e, tau_i)``: the least ``e >= 0`` by which joint ``i``'s limits must widen for the
    region ``A tau <= b`` to meet the limits box (the others kept); None if it never does."""
    p = A.shape[1]
    rows, rhs = [np.hstack([A, np.zeros((len(b), 1))])], [b]
    for k in range(p):
        e_k = np.zeros(p + 1)
        e_k[k] = 1.0
        slack = -1.0 if k == i else 0.0
        if math.isfinite(hi[k]):
            rows.append(np.r_[e_k[:p], slack][None])
            rhs.append(np.array([hi[k]]))
        if math.isfinite(lo[k]):
            rows.append(np.r_[-e_k[:p], slack][None])
            rhs.append(np.array([-lo[k]]))
    res = linprog(np.r_[np.zeros(p), 1.0], A_ub=np.vstack(rows), b_ub=np.concatenate(rhs),
                  bounds=[(None, None)] * p + [(0, None)], method="highs")
    if res.status != 0:
        return None
    return float(res.x[-1]), float(res.x[i])


def speed_limit_words(hand: Hand, j: int, rate: float, top: float, t: float) -> str:
    """A velocity-controlled joint's held rate above its speed limit."""
    unit = "rad/s" if effort_unit(hand, (j,)) == "N m" else "m/s"
    return (f"the joint limits leave no plan: at t = {t:.4g} s {joint_words(hand, j)} must move "
            f"at {rate:.4g} {unit}, above its speed limit {top:.4g} {unit}: {abs(rate) - top:.4g}"
            f" {unit} too fast; raise the limit or slow the segment down")

