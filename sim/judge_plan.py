"""Judging a plan run (:class:`sim.expectation.PlanSchedule`): every segment, then the whole.

A plan runs as one continuous simulation (:mod:`sim.schedule`): the recording is sliced per
segment -- segment ``k``'s steps in ``(T_k, T_k + D_k]``, only its own contacts' pairs, its
time counted from its start -- and each slice is judged as follows (tolerances in
docs/simulation.md, "Judging a run"):

* its steps at least the settling time after the segment's start (and after the contacts it
  gains touch) are classified (:mod:`sim.classify`); the claimed mode must be observed on
  :data:`~sim.verdict.MODE_FRACTION_REQUIRED` of them. A contact the claim has sliding whose
  predicted slip speed at that step (:func:`sim.schedule.predicted_slips`) is below the
  classifier's slip threshold shows the claim when it reads ``R`` as well: the classifier
  reads the predicted motion itself as rolling there (:func:`unresolved_slides`);
* the workpiece's position at the segment's last waypoint must be within
  :data:`~sim.verdict.POSE_TOLERANCE_OF_TRAVEL` of the segment's predicted travel from the
  predicted one, the predicted poses shifted by where the workpiece really was at the
  segment's start (each segment is judged on its own motion; the drift the segments add up is
  judged on the whole);
* a simulator fault in the segment makes it a ``fault`` (judged, as a whole run is, on its
  steps up to one window before: :func:`sim.verdict.fault_verdict`); later segments are not
  judged.

The whole plan is ``agreed`` when every segment agreed and the final position is within the
same fraction of the whole travel of the plan's last pose.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from planner.errors import InputError
from planner.model.modes import SLIDE, Mode
from sim.classify import Thresholds, judged_mask, observed_modes
from sim.expectation import (
    Judgement,
    PlanSchedule,
    SegmentExpectation,
    SegmentVerdict,
    point_errors,
    point_travel,
)
from sim.judge_soft import contact_sink
from sim.run import Recording
from sim.verdict import (
    MODE_FRACTION_REQUIRED,
    POSE_TOLERANCE_OF_TRAVEL,
    ObservedMode,
    Outcome,
    PlanMeasures,
    Verdict,
    count_labels,
    fault_verdict,
)


def judge_plan(rec: Recording, exp: PlanSchedule, th: Thresholds) -> Judgement:
    """Judge every segment of a plan run and the whole (module docstring)."""
    th = replace(th, jam_depth_rate=np.inf, jam_force=None)  # a plan predicts no jam
    iw = rec.body_names.index("workpiece")
    rows: list[SegmentVerdict] = []
    final_pose = None
    for k, seg in enumerate(exp.segments):
        t0, t1 = seg.start, seg.start + float(seg.times[-1])
        if len(rec.times) == 0 or rec.times[-1] <= t0 + 1e-9:
            break  # the recording ended (a fault) before this segment
        sub = slice_recording(rec, t0, t1, seg.pairs)
        start = (rec.poses[0, iw] if k == 0 else
                 rec.poses[int(np.searchsorted(rec.times, t0 - 1e-9)), iw])
        shift = np.asarray(start, dtype=float) - seg.planned_start if k > 0 else np.zeros(3)
        delay = touch_delay(sub, seg.gained)
        th_k = replace(th, settle=th.settle + (delay or 0.0), drive=seg.drive or th.drive,
                       slip_speed=seg.slip_speed or th.slip_speed)
        verdict = judge_segment(sub, seg, shift, th_k, exp.length)
        if delay is None:
            verdict = replace(verdict, outcome=Outcome.DISAGREED, reasons=verdict.reasons + (
                "a contact the segment gains never touched: "
                f"{[sub.pair_names[j] for j in seg.gained]}",))
        rows.append(SegmentVerdict(k, seg.claim.label, t0, float(seg.times[-1]),
                                   float(np.linalg.norm(shift[:2])), delay,
                                   tuple(rec.pair_names[i] for i in seg.pairs), verdict))
        if verdict.outcome is Outcome.FAULT:
            break
        if rec.fault is None and k == len(exp.segments) - 1:
            final_pose = rec.poses[-1, iw]
    whole = whole_verdict(exp, [r.verdict for r in rows], final_pose)
    observed = observed_modes(rec, th)
    return Judgement(whole, tuple(observed), tuple(rows))


def slice_recording(rec: Recording, t0: float, t1: float, pairs: Sequence[int]) -> Recording:
    """Steps of ``rec`` in ``(t0, t1]`` with only the columns of ``pairs`` (renamed ``c1 ..`` in
    that order: the segment's mode labels index them), times counted from ``t0``; the fault
    kept when it falls in the slice."""
    k0 = int(np.searchsorted(rec.times, t0 + 1e-9, side="left"))
    k1 = int(np.searchsorted(rec.times, t1 + 1e-9, side="right"))
    cols = list(pairs)
    per_pair = {f: getattr(rec, f)[k0:k1][:, cols] for f in (
        "present", "points", "normals", "normal_force", "tangent_force", "slip_velocity",
        "depth", "mu_used")}
    fault = rec.fault if rec.fault is not None and t0 < rec.fault.time <= t1 + 1e-9 else None
    if fault is not None:
        fault = replace(fault, time=fault.time - t0)
    return replace(rec, pair_names=tuple(f"c{i + 1}" for i in range(len(cols))),
                   times=rec.times[k0:k1] - t0, poses=rec.poses[k0:k1], fault=fault,
                   jammed_at=None, **per_pair)


def touch_delay(sub: Recording, cols: Sequence[int]) -> float | None:
    """Seconds from a segment's start until all its gained pairs ``cols`` touch (0 when they
    already do at its first step); ``None`` when they never do."""
    cols = list(cols)
    if not cols or len(sub.times) == 0:
        return 0.0
    all_on = np.all(sub.present[:, cols], axis=1)
    if not np.any(all_on):
        return None
    k = int(np.argmax(all_on))
    return 0.0 if k == 0 else float(sub.times[k])


def judge_segment(sub: Recording, seg: SegmentExpectation, shift: np.ndarray,
                  th: Thresholds, length: float) -> Verdict:
    """One segment's slice (module docstring); ``shift`` (3,) moves the predicted poses to
    where the segment really started."""
    poses = np.asarray(seg.poses, dtype=float) + shift
    if sub.fault is not None:
        before = sub.until(sub.fault.time - th.window)
        return fault_verdict(sub.fault, _judge_steps(before, observed_modes(before, th), th,
                                                     seg, poses, length))
    return _judge_steps(sub, observed_modes(sub, th), th, seg, poses, length) or Verdict(
        Outcome.INCONCLUSIVE, ("no step could be judged",))


def _judge_steps(rec: Recording, observed: list[ObservedMode], th: Thresholds,
                 seg: SegmentExpectation, pred_poses: np.ndarray, length: float
                 ) -> Verdict | None:
    """The verdict of a segment's steps (a run that ended normally, or the part of a faulted
    one before its fault); None when nothing can be judged."""
    t = np.asarray(seg.times, dtype=float)
    iw = rec.body_names.index("workpiece")
    if len(rec.times) == 0:
        return None
    mask = judged_mask(rec, th)
    judged = [o for o, m in zip(observed, mask) if m]
    # waypoints passed by the run (all of them unless it stopped early), plus its last step
    t_end = float(rec.times[-1])
    n_wp = int(np.searchsorted(t, t_end + 1e-9))
    t_cmp = t[:n_wp] if n_wp == len(t) else np.append(t[:n_wp], t_end)
    if n_wp < len(t):
        pred_poses = np.vstack([pred_poses[:n_wp], [np.interp(t_end, t, pred_poses[:, c])
                                                   for c in range(3)]])
    k = np.clip(np.searchsorted(rec.times, t_cmp - 1e-9), 0, len(rec.times) - 1)
    if not judged:
        # before the settling time only the pose can be judged (modes need settling)
        off = float(point_errors(rec.poses[-1:, iw], pred_poses[-1:], seg.points)[0])
        travel = point_travel(pred_poses[[0, -1]], seg.points)
        if off > POSE_TOLERANCE_OF_TRAVEL * max(travel, 0.01 * length):
            return Verdict(Outcome.DISAGREED, (
                f"the workpiece left the planned path before the settling time: "
                f"{off:.3g} m from the predicted position at t = {t_end:.3f} s",))
        return Verdict(Outcome.INCONCLUSIVE, ("no step after the settling time was recorded",))
    settled = np.flatnonzero(mask)
    interval = np.clip(np.searchsorted(t, rec.times[settled], side="right") - 1, 0, len(t) - 2)
    try:
        return compare_plan(seg.claim, judged, [seg.predicted[j] for j in interval], pred_poses,
                            rec.poses[k, iw], interval=interval, points=seg.points,
                            sink=contact_sink(rec),
                            unresolved=unresolved_slides(seg, rec.times[settled],
                                                         th.slip_speed))
    except InputError:
        return None  # no predicted travel yet


def unresolved_slides(seg: SegmentExpectation, times: np.ndarray, slip_speed: float
                      ) -> np.ndarray:
    """(m, n_c) bool: at each of the ``times`` (m,) [s, the segment's clock], the contacts the
    segment's claim has sliding whose predicted slip speed ``|v_it|`` (``seg.slips``,
    interpolated between waypoints) is below ``slip_speed`` [m/s], the classifier's slip
    threshold: the classifier reads the predicted motion itself as ``R`` there (a window mean
    of ``|v_t|`` at most the threshold is rolling, :mod:`sim.classify`), so ``R`` and the
    claimed ``S`` are one reading of such a contact. All False without predicted slips."""
    times = np.asarray(times, dtype=float)
    slips = np.asarray(seg.slips, dtype=float)
    n_c = len(seg.claim.codes)
    out = np.zeros((len(times), n_c), dtype=bool)
    if slips.shape != (len(seg.times), n_c) or len(seg.times) < 2:
        return out
    for i, code in enumerate(seg.claim.codes):
        if code == SLIDE:
            out[:, i] = np.abs(np.interp(times, seg.times, slips[:, i])) < slip_speed
    return out


def shows_claim(observed: ObservedMode, claim: Mode, unresolved: np.ndarray | None = None
                ) -> bool:
    """Whether ``observed`` shows ``claim``: every contact reads the claimed token, except
    that a contact flagged in ``unresolved`` (n_c,) may read ``R`` where the claim slides
    (:func:`unresolved_slides`)."""
    if observed == claim:
        return True
    if unresolved is None or isinstance(observed, str) or not np.any(unresolved):
        return False
    obs, want = observed.tokens, claim.tokens
    return len(obs) == len(want) and all(
        o == w or (bool(unresolved[i]) and o == "R") for i, (o, w) in enumerate(zip(obs, want)))


def _poses(name: str, value: np.ndarray, n: int) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (n, 3):
        raise InputError(f"{name}: expected shape ({n}, 3) (x, y, theta per waypoint), "
                         f"got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected finite numbers, got NaN or inf")
    return arr


def compare_plan(
    claim: Mode,
    observed: Sequence[ObservedMode],
    predicted: Sequence[frozenset[ObservedMode]],
    predicted_poses: np.ndarray,
    simulated_poses: np.ndarray,
    *,
    interval: Sequence[int] | np.ndarray | None = None,
    unresolved: np.ndarray | None = None,
    points: np.ndarray | None = None,
    sink: float = 0.0,
    mode_fraction: float = MODE_FRACTION_REQUIRED,
    pose_tolerance: float = POSE_TOLERANCE_OF_TRAVEL,
) -> Verdict:
    """Observed modes and poses of a segment against its claim, predictions and poses.

    ``observed`` (m,) judged steps; ``predicted`` (m,) the predicted mode set of each step's
    waypoint interval; ``interval`` (m,) that interval's index (default: all 0);
    ``unresolved`` (m, n_c) bool the contacts whose claimed slide is slower than the slip
    threshold at each step (:func:`unresolved_slides`; default none: the claim's tokens
    exactly);
    ``predicted_poses``, ``simulated_poses`` (n, 3) ``(x, y, theta)`` [m, m, rad] at the n
    waypoints; ``points`` (k, 2) [m] the body-frame workpiece points whose positions are
    compared (a plan run's: the centre of mass; default the frame origin): the travel is the
    longest of their paths, a position error the largest of their distances
    (:func:`sim.expectation.point_travel`, :func:`~sim.expectation.point_errors`), so neither
    depends on where the user put the workpiece's frame. ``agreed`` when the claim holds on
    ``>= mode_fraction`` of the judged steps and the final position is within
    ``pose_tolerance`` of the travel plus ``sink`` [m], the deepest the run's contacts sank
    (:func:`contact_sink`; default 0: the fraction alone).
    """
    m = len(observed)
    if m == 0:
        raise InputError("observed: expected at least one judged step, got none")
    if len(predicted) != m:
        raise InputError(f"predicted: expected {m} mode sets (one per step), got {len(predicted)}")
    n = len(np.asarray(predicted_poses, dtype=float))
    if n < 2:
        raise InputError(f"predicted_poses: expected at least 2 waypoints, got {n}")
    pred = _poses("predicted_poses", predicted_poses, n)
    simu = _poses("simulated_poses", simulated_poses, n)
    idx = np.zeros(m, dtype=int) if interval is None else np.asarray(interval, dtype=int)
    if idx.shape != (m,):
        raise InputError(f"interval: expected {m} indices, got shape {idx.shape}")
    pts = np.zeros((1, 2)) if points is None else np.asarray(points, dtype=float)
    travel = point_travel(pred, pts)
    if travel <= 0.0:
        raise InputError("predicted_poses: expected a segment with positive travel, got 0")
    slow = (np.zeros((m, len(claim.codes)), dtype=bool) if unresolved is None
            else np.asarray(unresolved, dtype=bool))
    if slow.shape != (m, len(claim.codes)):
        raise InputError(f"unresolved: expected shape ({m}, {len(claim.codes)}), got "
                         f"{slow.shape}")
    shown = [shows_claim(o, claim, u) for o, u in zip(observed, slow)]
    claim_frac = float(np.mean(shown))
    read_r = float(np.mean([o != claim and s for o, s in zip(observed, shown)]))
    pred_frac = float(np.mean([o in p for o, p in zip(observed, predicted)]))
    errs = point_errors(simu, pred, pts)
    counts = count_labels(observed)
    per_wp = []
    for k in range(int(idx.max()) + 1):
        here = count_labels([o for o, j in zip(observed, idx) if j == k])
        per_wp.append(max(here, key=lambda kv: kv[1])[0] if here else "")
    reasons = []
    if claim_frac < mode_fraction:
        others = sorted(((c, lab) for lab, c in counts if lab != claim.label), reverse=True)
        top = (f"; most observed instead: {others[0][1]!r} ({others[0][0] / m:.1%})"
               if others else "")
        reasons.append(f"claimed mode {claim.label!r} observed on {claim_frac:.1%} of the "
                       f"segment, required {mode_fraction:.0%}{top}")
    err = float(errs[-1])
    off = err > pose_tolerance * travel + sink
    if off:
        extra = f" + the contacts' sink {sink:.3g} m" if sink > 0 else ""
        reasons.append(f"final position off by {err:.4g} m = {err / travel:.1%} of travel "
                       f"{travel:.4g} m, allowed {pose_tolerance:.0%}{extra}")
    measures = PlanMeasures(claim, claim_frac, pred_frac, err, travel,
                            float(abs(simu[-1, 2] - pred[-1, 2])), float(errs.max() / travel),
                            tuple(per_wp))
    if not reasons:
        reasons.append(f"{claim_frac:.1%} of the segment in the claimed mode, final position "
                       f"{err / travel:.2%} of travel from the prediction")
    if slow.any():
        who = ", ".join(str(i + 1) for i in np.flatnonzero(slow.any(axis=0)))
        reasons.append(f"claimed slides slower than the slip threshold (contact {who}) on "
                       f"{np.mean(slow.any(axis=1)):.1%} of the segment: read as R or S there; "
                       f"{read_r:.1%} of the segment showed the claim so")
    return Verdict(Outcome.DISAGREED if claim_frac < mode_fraction or off
                   else Outcome.AGREED, tuple(reasons), agreement=claim_frac,
                   judged_steps=m, observed_counts=counts, plan=measures)


def whole_verdict(exp: PlanSchedule, verdicts: Sequence[Verdict],
                  final: np.ndarray | None) -> Verdict:
    """The whole plan's verdict from its segments' and its final pose (module docstring); a
    single-segment plan's is its segment's."""
    n = len(exp.segments)
    if n == 1 and verdicts:
        return verdicts[0]
    outcomes = [v.outcome for v in verdicts]
    reasons = [f"segment {k + 1}: {v.outcome.value}" + (f" ({v.reason})" if v.reasons else "")
               for k, v in enumerate(verdicts) if v.outcome is not Outcome.AGREED]
    if len(verdicts) < n:
        reasons.append(f"only {len(verdicts)} of {n} segments ran")
    if final is None:
        reasons.append("no final position: the run stopped before the end of the plan")
    elif (off := float(point_errors(final[None, :], exp.goal[None, :], exp.points)[0])) > (
            POSE_TOLERANCE_OF_TRAVEL * exp.travel):
        reasons.append(f"final position {off:.3g} m from the plan's, more than "
                       f"{POSE_TOLERANCE_OF_TRAVEL:.0%} of the travel {exp.travel:.3g} m")
    agreement = float(np.mean([v.agreement for v in verdicts])) if verdicts else 0.0
    judged = sum(v.judged_steps for v in verdicts)
    if Outcome.FAULT in outcomes:
        fault = next(v.fault for v in verdicts if v.outcome is Outcome.FAULT)
        return Verdict(Outcome.FAULT, tuple(reasons), agreement, judged, fault=fault)
    if not reasons:
        return Verdict(Outcome.AGREED, (f"all {n} segments agreed; final position within "
                                        f"{POSE_TOLERANCE_OF_TRAVEL:.0%} of the travel",),
                       agreement, judged)
    bad = (Outcome.INCONCLUSIVE if Outcome.INCONCLUSIVE in outcomes
           and Outcome.DISAGREED not in outcomes else Outcome.DISAGREED)
    return Verdict(bad, tuple(reasons), agreement, judged)
