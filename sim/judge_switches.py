"""Judging a ruler run (:class:`sim.expectation.Switches`, Sec. 5.1): where the sliding finger
hands over to the other, against the predicted switch positions.

From the simulator's contact data only: the finger that carries the motion per step
(:func:`sliding_finger`: its window-mean slip above the slip threshold and above
:data:`DOMINANCE` times the other's), the switch positions where that finger changes
(:func:`observed_switches`), matched to the predicted ones (:func:`compare_switches`). A miss in
an engine whose "sticking" finger creeps faster than the slip threshold is ``inconclusive`` when
the creep explains it (:func:`creep_verdict`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from sim.classify import Thresholds, mode_of, window_mean, window_tokens
from sim.expectation import Judgement, Switches
from sim.run import Recording
from sim.verdict import ObservedMode, Outcome, Verdict, fault_verdict


def judge_switches(rec: Recording, exp: Switches, th: Thresholds) -> Judgement:
    """Judge a ruler run (module docstring)."""
    tokens = window_tokens(rec, th)
    observed: tuple[ObservedMode, ...] = tuple(mode_of(tuple(r)) for r in tokens)
    slider = sliding_finger(rec, th.slip_speed, th.window)
    positions, sliders, times = observed_switches(rec, slider, rec.body_names, th.window)
    creep_speed = creep(rec, slider, th.window) if len(rec.times) else 0.0
    need = min(exp.required, len(exp.positions))
    details: dict[str, object] = {"switch_positions_m": positions, "sliding_fingers": sliders,
                                  "switch_times_s": times, "creep_m_per_s": creep_speed}
    if rec.fault is not None:
        return Judgement(fault_verdict(rec.fault), observed, details=details)
    verdict, errors = compare_switches(exp.positions, exp.sliders, positions, sliders,
                                       tolerance=exp.tolerance, required=need)
    verdict = creep_verdict(verdict, errors, list(exp.positions[:need]), positions, times,
                            creep_speed, th.slip_speed, exp.tolerance)
    details["relative_errors"] = errors
    return Judgement(verdict, observed, details=details)


#: A finger carries the motion when its window-mean slip exceeds the slip threshold and this
#: many times the other finger's (a creeping "sticking" finger does not hide which one slides).
DOMINANCE = 2.0


def sliding_finger(rec: Recording, slip_speed: float, window: float) -> np.ndarray:
    """(T,) index of the finger that carries the motion (0 left, 1 right), -1 where neither
    or both do: window-mean ``|v_t|`` (:func:`sim.classify.window_mean`) above ``slip_speed``
    and above :data:`DOMINANCE` times the other finger's."""
    v = np.abs(window_mean(rec.slip_velocity, rec.present.astype(float), rec.times, window))
    v = np.nan_to_num(v, nan=0.0)
    out = np.full(len(rec.times), -1)
    for i in (0, 1):
        out[(v[:, i] > slip_speed) & (v[:, i] > DOMINANCE * v[:, 1 - i])] = i
    return out


def observed_switches(rec: Recording, slider: np.ndarray, body_names: tuple[str, ...],
                      window: float = 0.0) -> tuple[list[float], list[int], list[float]]:
    """Switch positions from a recording and its sliding finger per step (``slider``, from
    :func:`sliding_finger` with averaging ``window`` [s]): when the sliding finger changes from
    ``i`` to ``j``, the distance of finger ``i`` to the rod's COM [m]. Returns the positions,
    the fingers ``i`` and the times [s] of the switches.

    Dating: the window means of the two slips cross at a hand-over; the stretch where neither
    finger dominates is about symmetric around the crossing and is dated at its middle. A
    stretch longer than one window (the fingers chatter, or both slide after the last switch)
    is dated where finger ``i`` stopped dominating, less half a window (the centred mean's lag);
    so is a run that ends without another sliding finger."""
    iw = body_names.index("workpiece")
    ifs = [body_names.index("finger1"), body_names.index("finger2")]
    T = len(rec.times)
    step = float(rec.times[1] - rec.times[0]) if T > 1 else 1.0
    lag = int(round(0.5 * window / step))
    positions: list[float] = []
    sliders: list[int] = []
    times: list[float] = []

    def record(finger: int, k: int) -> None:
        k = min(max(k, 0), T - 1)
        xc = rec.poses[k, iw, 0]
        positions.append(float(abs(rec.poses[k, ifs[finger], 0] - xc)))
        sliders.append(finger)
        times.append(float(rec.times[k]))

    prev, end = -1, -1  # current sliding finger, the last step it dominated
    for k in range(T):
        cur = int(slider[k])
        if cur < 0:
            continue
        if prev >= 0 and cur != prev:
            gap = k - end - 1
            record(prev, (end + k + 1) // 2 if gap * step <= window else end + 1 - lag)
        prev, end = cur, k
    if prev >= 0 and end < T - 1:
        record(prev, end + 1 - lag)
    return positions, sliders, times


def creep(rec: Recording, slider: np.ndarray, window: float) -> float:
    """Median window-mean ``|v_t|`` [m/s] of the finger that does *not* carry the motion
    (predicted to stick) while the other one does, away from the hand-overs (steps more than
    one window inside a stretch of one sliding finger): the engine's measured creep."""
    v = np.abs(np.nan_to_num(window_mean(rec.slip_velocity, rec.present.astype(float),
                                         rec.times, window)))
    T = len(rec.times)
    step = float(rec.times[1] - rec.times[0]) if T > 1 else 1.0
    m = max(1, int(round(window / step)))
    inside = np.zeros(T, dtype=bool)
    for k in range(m, T - m):
        inside[k] = slider[k] >= 0 and bool(np.all(slider[k - m:k + m + 1] == slider[k]))
    rest = np.concatenate([v[inside & (slider == i), 1 - i] for i in (0, 1)])
    return float(np.median(rest)) if len(rest) else 0.0


def compare_switches(predicted: Sequence[float], predicted_sliders: Sequence[int],
                     observed: Sequence[float], observed_sliders: Sequence[int], *,
                     tolerance: float, required: int) -> tuple[Verdict, list[float | None]]:
    """Ruler switch positions (Sec. 5.1): each predicted switch ``k`` [m] is matched to the
    observed switch of the same sliding finger nearest to it along the motion (not by list
    index), each observed switch used once, in order. A predicted switch matches when its
    relative error is within ``tolerance``; ``agreed`` when the first ``required`` predicted
    switches all match. Returns the verdict and the per-predicted-switch relative errors
    (``None`` where no observed switch of that finger is left)."""
    need = min(required, len(predicted))
    errors: list[float | None] = []
    used = -1
    for p, s in zip(predicted, predicted_sliders):
        cands = [(abs(o - p) / p, j) for j, (o, so) in enumerate(zip(observed, observed_sliders))
                 if j > used and so == s]
        if not cands:
            errors.append(None)
            continue
        err, j = min(cands)
        errors.append(float(err))
        if err <= tolerance:
            used = j
    matched = sum(1 for e in errors[:need] if e is not None and e <= tolerance)
    agreement = matched / need if need else 0.0
    shown = [None if e is None else round(e, 4) for e in errors]
    if need == 0:
        return Verdict(Outcome.INCONCLUSIVE, ("no switch predicted",)), errors
    outcome = Outcome.AGREED if matched == need else Outcome.DISAGREED
    return Verdict(outcome, (f"{matched} of {need} predicted switches within {tolerance:.0%} "
                             f"(relative errors {shown})",), agreement=agreement,
                   judged_steps=need), errors


def creep_verdict(verdict: Verdict, errors: list[float | None], predicted: list[float],
                  observed: list[float], times: list[float], creep_speed: float,
                  slip_speed: float, tolerance: float) -> Verdict:
    """A ruler disagreement in an engine whose "sticking" finger creeps faster than the slip
    threshold is ``inconclusive`` when the creep can explain every missed switch: switch ``k``
    may be off by the creep displacement up to its observed time, ``creep * t_k``, relative to
    its predicted position (on top of ``tolerance``). A miss beyond that stays ``disagreed``."""
    if verdict.outcome is not Outcome.DISAGREED or not creep_speed > slip_speed:
        return verdict
    t_max = max(times) if times else 0.0
    for e, p in zip(errors, predicted):
        t_k = t_max if e is None else min(
            (t for o, t in zip(observed, times) if abs(o - p) / p == e), default=t_max)
        allowed = tolerance + creep_speed * t_k / p
        if e is None or e > allowed:
            return verdict
    return replace(verdict, outcome=Outcome.INCONCLUSIVE, reasons=verdict.reasons + (
        f"the sticking finger creeps at {creep_speed:.3g} m/s, above the slip threshold "
        f"{slip_speed:.3g} m/s: the misses are within the creep's displacement, so this "
        f"engine cannot tell here",))
