"""The one judge: a recording against an expectation (:mod:`sim.expectation`) gives the one
:class:`~sim.verdict.Verdict` (:func:`judge`).

Observations come from the simulator's own contact data and body poses only
(:mod:`sim.classify`); the expectation from the planner. A :class:`~sim.expectation.ModeSet` is
judged here, a :class:`~sim.expectation.PlanSchedule` by :mod:`sim.judge_plan`, a
:class:`~sim.expectation.Switches` by :mod:`sim.judge_switches`.

A system run (:func:`judge_modes`; tolerances derived in docs/simulation.md, "Judging a run"):

1. **modes** -- every judged step (after the settling time) whose observed mode is *consistent*
   with a predicted mode counts; ``agreed`` needs :data:`~sim.verdict.MODE_FRACTION_REQUIRED`
   of them. An observed mode is consistent with a predicted one when every contact shows the
   predicted token, except that (a) at a contact whose judged friction is zero, rolling and
   sliding are one closed state (their force constraints coincide, ``c_t = 0``; the slip is the
   workpiece's motion, judged by the twist), (b) a contact observed carrying no load (``B``)
   where the mode has it closed is consistent when a member of the mode's certificate family
   loads all such contacts by at most the force check's allowance (item 3;
   :func:`planner.predict.family.admits_unloaded`, :func:`sim.judge_soft.unload_allowance`):
   the run shows one of the mode's certificates, not another mode; (c) a contact the mode
   opens may read loaded until the predicted motion has lifted it out of the depth the engine
   measured there (:func:`sim.judge_soft.clearing_times`: a support sunk in the table stays
   loaded while it rises, at the predicted speed where the engine touches it); and (d) over
   the stretch of item 2, a closed contact shows the predicted token when its bodies' relative
   motion there reads as it (:func:`sim.judge_soft.stretch_readings`: a soft contact's
   elastic give flickers its window slip reading, not the bodies' motion);
2. **twist** -- the workpieces' mean twist over the stretch of judged steps in which the
   certificate's configuration holds (:func:`twist_stretch`: every workpiece within
   :data:`~sim.verdict.FORCE_DRIFT_LIMIT` of its size of its start, measured; at least
   ``early`` seconds) against the reference mode's ``qdot`` (the most observed consistent
   mode), error ``max_b |q_obs,b - q_pred,b|_L / max(|q_pred|_L, drive)`` within
   :data:`~sim.verdict.TWIST_TOLERANCE` (:func:`sim.classify.twist_error`; absolute where the
   predicted twist is slower than the drive: a workpiece predicted to stay);
3. **forces** -- the mean contact forces of the first ``early`` seconds of judged steps in the
   reference mode itself (no contact still clearing its depth) against the nearest member of
   its certificate family (:func:`planner.predict.family.nearest_certificate`) within
   :data:`~sim.verdict.FORCE_TOLERANCE` of that member's total normal force (never less than
   the load), while the workpiece is near the certificate's configuration (within
   :data:`~sim.verdict.FORCE_DRIFT_LIMIT` of its size);
4. **engine limits** -- a force miss while the contacts flicker, or a mode miss while the
   workpiece moves as predicted and kept contacts go missing (stick-slip, chatter), is
   ``inconclusive`` with the measured cause, never ``disagreed``;
5. **faults** -- a run that faulted is a ``fault`` unless its steps before the fault already
   disagreed (:func:`sim.verdict.fault_verdict`); a predicted jam whose drive pushed the
   bodies into each other (a penetration fault) agrees.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from planner.model.modes import BREAK
from planner.predict.family import admits_unloaded, nearest_certificate
from planner.predict.stages import FeasibleMode
from sim.classify import (
    Thresholds,
    correction_steps,
    flicker_fraction,
    judged_mask,
    observed_modes,
    twist_error,
)
from sim.expectation import Expectation, Judgement, ModeSet, PlanSchedule, Switches
from sim.judge_soft import (
    certificate_scale,
    clearing_times,
    contact_sink,
    stretch_readings,
    unexplained_reach,
    unload_allowance,
)
from sim.run import FaultKind, Recording
from sim.verdict import (
    FORCE_DRIFT_LIMIT,
    FORCE_TOLERANCE,
    JAM,
    MODE_FRACTION_REQUIRED,
    TWIST_TOLERANCE,
    MotionMeasures,
    ObservedMode,
    Outcome,
    Verdict,
    count_labels,
    fault_verdict,
)

#: A ``disagreed`` mode comparison is ``inconclusive`` when the workpiece's mean twist is within
#: :data:`~sim.verdict.TWIST_TOLERANCE` of a predicted one while contacts the nearest mode keeps
#: closed are missing on more than this fraction of the judged steps: a resting contact is never
#: missing in a sound run (pymunk runs of the shipped systems miss none), so the engine is
#: stick-slipping or chattering (docs/simulation.md, "Judging a run").
LOST_FRACTION = 0.01


def judge(rec: Recording, expectation: Expectation, th: Thresholds) -> Judgement:
    """Judge ``rec`` against ``expectation`` with thresholds ``th`` (module docstring)."""
    if isinstance(expectation, ModeSet):
        verdict, observed = judge_modes(rec, expectation, th)
        return Judgement(verdict, tuple(observed))
    if isinstance(expectation, PlanSchedule):
        from sim.judge_plan import judge_plan

        return judge_plan(rec, expectation, th)
    if isinstance(expectation, Switches):
        from sim.judge_switches import judge_switches

        return judge_switches(rec, expectation, th)
    raise TypeError(f"expectation: expected ModeSet, PlanSchedule or Switches, got "
                    f"{type(expectation).__name__}")


# ---- consistency of an observed mode with a predicted one ---------------------------------------
class ModeMatcher:
    """Which predicted modes an observed mode is consistent with (module docstring, 1),
    cached per observed label (and per set of contacts still clearing their depth).

    ``clear_until`` (n_modes, n_c) [s]: run time until which a contact the mode opens may still
    be loaded (:func:`sim.judge_soft.clearing_times`); ``None``: none may. ``moves_as``
    (n_modes, n_c) bool: the contact's relative motion over the stretch reads as the mode's
    token (:func:`sim.judge_soft.stretch_readings`), used for the steps up to ``moves_until``
    [s] (the end of that stretch); ``None``: not used."""

    def __init__(self, expectation: ModeSet, clear_until: np.ndarray | None = None,
                 moves_as: np.ndarray | None = None, moves_until: float = -np.inf) -> None:
        self.exp = expectation
        mu = (np.asarray(expectation.system.mu, dtype=float) if expectation.system is not None
              else None)
        self.frictionless = (mu == 0.0) if mu is not None else None
        self.clear_until = clear_until
        self.moves_as = moves_as
        self.moves_until = moves_until
        self._cache: dict[tuple[str, int, tuple[int, ...], bool], bool] = {}

    def matches(self, observed: ObservedMode, t: float = np.inf, clear: bool = True
                ) -> tuple[int, ...]:
        """Indices of the predicted modes ``observed`` at run time ``t`` [s] is consistent
        with (``JAM``: none); ``clear=False``: no contact excused as still clearing its
        depth (the mode itself)."""
        if isinstance(observed, str):
            return ()
        out = []
        moving = self.moves_as is not None and t <= self.moves_until
        for k, m in enumerate(self.exp.modes):
            clearing: tuple[int, ...] = ()
            if self.clear_until is not None and clear:
                clearing = tuple(int(i) for i in np.flatnonzero(t < self.clear_until[k]))
            key = (observed.label, k, clearing, moving)
            if key not in self._cache:
                self._cache[key] = self._consistent(observed.tokens, m, clearing,
                                                    k if moving else -1)
            if self._cache[key]:
                out.append(k)
        return tuple(out)

    def _consistent(self, obs: tuple[str, ...], mode: FeasibleMode,
                    clearing: tuple[int, ...] = (), moving: int = -1) -> bool:
        """``moving``: the index of ``mode`` when a closed contact may be read by its bodies'
        relative motion over the stretch (``moves_as``), else -1."""
        pred = mode.mode.tokens
        if len(obs) != len(pred):
            return False
        unloaded = []
        for i, (o, p) in enumerate(zip(obs, pred)):
            if o == p:
                continue
            if p == "B" and i in clearing:
                continue  # opening, but not yet lifted out of its measured depth
            if o != "B" and moving >= 0 and self.moves_as is not None and \
                    self.moves_as[moving, i]:
                continue  # a closed contact whose bodies move over the stretch as predicted
            if (self.frictionless is not None and self.frictionless[i] and o != "B"
                    and p != "B"):
                continue  # rolling and sliding are one closed state at zero friction
            if o == "B" and mode.mode.codes[i] != BREAK:
                unloaded.append(i)
                continue
            return False
        if not unloaded:
            return True
        return self.exp.system is not None and admits_unloaded(
            self.exp.system, mode.mode, unloaded, unload_allowance(mode, self.exp.load))


# ---- a system run ---------------------------------------------------------------------------
def judge_modes(rec: Recording, exp: ModeSet, th: Thresholds
                ) -> tuple[Verdict, list[ObservedMode]]:
    """Classify ``rec`` and judge it against the predicted modes (module docstring). Returns
    ``(verdict, observed mode per recorded step)``."""
    observed = observed_modes(rec, th, exp.twists(), exp.bodies)
    if exp.static and not exp.modes:
        return judge_moves(rec, exp, th), observed
    if rec.fault is not None:
        if not exp.modes and rec.fault.kind is FaultKind.PENETRATION:
            return Verdict(Outcome.AGREED, (
                f"predicted jam; the drive pushed the bodies into each other: "
                f"{rec.fault.reason}",), agreement=1.0, fault=rec.fault), observed
        # what the run showed up to one window before the fault (its blow-up excluded): a
        # disagreement there means the run had left the prediction
        before, _ = judge_modes(rec.until(rec.fault.time - th.window), exp, th)
        return fault_verdict(rec.fault, before), observed
    mask = judged_mask(rec, th)
    judged = [o for o, k in zip(observed, mask) if k]
    if not judged:
        return Verdict(Outcome.INCONCLUSIVE, ("no step could be judged (the run ended before "
                                              "the settling time)",)), observed
    times = rec.times[mask]
    # the workpieces' mean twist over the stretch: read by the matcher and by the twist check
    q_obs, until = (_judged_twist(rec, exp, th, mask) if exp.modes and len(judged) > 1
                    else (None, -np.inf))
    moves_as = (stretch_readings(exp, q_obs, th.slip_speed)
                if q_obs is not None and exp.system is not None else None)
    matcher = ModeMatcher(exp, clearing_times(rec, exp, th, mask) if exp.modes else None,
                          moves_as, until)
    hits = [bool(matcher.matches(o, t)) if exp.modes else o == JAM
            for o, t in zip(judged, times)]
    agreement = float(np.mean(hits))
    counts = count_labels(judged)
    outcome = Outcome.AGREED if agreement >= MODE_FRACTION_REQUIRED else Outcome.DISAGREED
    reasons = [f"{agreement:.1%} of {len(judged)} judged steps show a predicted mode "
               f"(required {MODE_FRACTION_REQUIRED:.0%})"]
    base = Verdict(outcome, tuple(reasons), agreement=agreement, judged_steps=len(judged),
                   observed_counts=counts)
    if q_obs is None:  # no modes, or fewer than two judged steps
        return _moved_by_correction(base, rec, exp, th, mask, judged), observed
    verdict = _motion(rec, exp, th, judged, mask, matcher, base, q_obs)
    if verdict.outcome is Outcome.DISAGREED and agreement < MODE_FRACTION_REQUIRED:
        verdict = _engine_cannot_tell(verdict, rec, exp, th, mask)
    return _moved_by_correction(verdict, rec, exp, th, mask, judged), observed


def judge_moves(rec: Recording, exp: ModeSet, th: Thresholds) -> Verdict:
    """A static system without a predicted equilibrium: ``agreed`` when a workpiece moves away
    from its start faster than :data:`~sim.verdict.TWIST_TOLERANCE` of the drive speed (the
    speed the classifier resolves, :class:`sim.expectation.ModeSet`): its largest displacement
    from the first recorded pose (rotation weighted by ``th.length_scale``) per second of the
    run, up to a fault that ends it (it left the scene or ran into something).

    Measured from the start, not over the judged steps: with nothing driven there is no drive to
    ramp up, and a workpiece without an equilibrium is already moving before the settling time
    -- a block sliding down an incline slides off the surfaces the scene models under its
    corners (``sim.scenes.shapes.ENV_INSET``) and can come to rest there, after the settling
    time; the pre-load relaxation (``PRELOAD`` of the size) stays 60x below the limit over a
    run (docs/simulation.md, "Static questions")."""
    run = rec.until(rec.fault.time) if rec.fault is not None else rec
    if rec.fault is not None and rec.fault.kind not in (FaultKind.LEFT_SCENE,
                                                        FaultKind.PENETRATION):
        return fault_verdict(rec.fault)
    if len(run.times) < 2:
        return Verdict(Outcome.INCONCLUSIVE, ("no step could be judged",))
    dt = float(run.times[-1] - run.times[0])
    sink = contact_sink(run)
    reach = max(0.0, float(np.max(unexplained_reach(run, exp, th.length_scale))) - sink)
    speed = reach / dt if dt > 0 else 0.0
    moved = speed > TWIST_TOLERANCE * exp.drive
    how = (f"a workpiece moved {reach:.3g} m from its start in {dt:.3g} s ({speed:.3g} m/s) beyond "
           f"its contacts' sinking (deepest {sink:.3g} m)"
           + (f", then {rec.fault.reason}" if rec.fault is not None else ""))
    judged = int(judged_mask(run, th).sum())
    if moved:
        return Verdict(Outcome.AGREED, (f"no static equilibrium predicted; {how}",),
                       agreement=1.0, judged_steps=judged, fault=rec.fault)
    return Verdict(Outcome.DISAGREED, (
        f"no static equilibrium predicted, but the workpieces stayed: {how}, below "
        f"{TWIST_TOLERANCE:.0%} of the reference speed {exp.drive:.3g} m/s",),
        judged_steps=judged)


def drift_from_start(poses: np.ndarray, start: np.ndarray, length: float) -> np.ndarray:
    """(T,) largest distance of a workpiece from its pose ``start`` (n_b, 3) -- the
    certificate's configuration -- over ``length`` [m] (rotation weighted by it), for poses
    (T, n_b, 3)."""
    d = np.asarray(poses, dtype=float) - np.asarray(start, dtype=float)[None]
    d[..., 2] = (d[..., 2] + np.pi) % (2.0 * np.pi) - np.pi
    return np.max(np.linalg.norm(d * np.array([1.0, 1.0, length]), axis=-1), axis=-1) / length


def twist_stretch(times: np.ndarray, poses: np.ndarray, start: np.ndarray, length: float,
                  early: float) -> int:
    """Last index of the stretch of judged steps (``times`` (T,), ``poses`` (T, n_b, 3)) over
    which twist and forces are compared with the certificates: every step up to which each
    workpiece has stayed within :data:`~sim.verdict.FORCE_DRIFT_LIMIT` of its size (``length``
    [m]) of the certificate's configuration ``start`` (the run's first poses; measured, not
    predicted), and never fewer than the first ``early`` seconds (all steps when the run is
    shorter). The certificates hold at that configuration; a soft engine's pose is off the
    rigid one by up to its penetration depth, an error of up to ``depth / T`` in a twist
    measured over ``T``, and a stick-slip cycle shorter than ``T`` averages out: the stretch is
    as long as the configuration allows (docs/simulation.md, "Twist and forces")."""
    first = times <= float(times[0]) + early + 1e-12
    floor = int(np.flatnonzero(first)[-1])
    if floor == 0:
        floor = len(times) - 1
    over = np.flatnonzero(drift_from_start(poses, start, length) > FORCE_DRIFT_LIMIT)
    end = int(over[0]) - 1 if over.size else len(times) - 1
    return max(end, floor)


def _stretch_twist(times: np.ndarray, poses: np.ndarray, k1: int) -> np.ndarray:
    """Mean twist ``(3 n_b,)`` of ``poses`` (T, n_b, 3) from the first step to step ``k1``
    (angles unwrapped)."""
    pose = poses.copy()
    pose[:, :, 2] = np.unwrap(pose[:, :, 2], axis=0)
    return ((pose[k1] - pose[0]) / float(times[k1] - times[0])).reshape(-1)


def _judged_twist(rec: Recording, exp: ModeSet, th: Thresholds, mask: np.ndarray
                  ) -> tuple[np.ndarray, float]:
    """The workpieces' mean twist ``(3 n_b,)`` over the stretch of judged steps
    (:func:`twist_stretch`) and the run time [s] the stretch ends."""
    idx = [rec.body_names.index(b) for b in exp.bodies]
    times, poses = rec.times[mask], rec.poses[mask][:, idx]
    k1 = twist_stretch(times, poses, rec.poses[0][idx], th.length_scale, th.early)
    return _stretch_twist(times, poses, k1), float(times[k1])


def _motion(rec: Recording, exp: ModeSet, th: Thresholds, judged: Sequence[ObservedMode],
            mask: np.ndarray, matcher: ModeMatcher, base: Verdict, q_obs: np.ndarray
            ) -> Verdict:
    """Twist and forces of the judged steps against the reference mode (module docstring,
    2-4); ``q_obs`` (3 n_b,) the workpieces' mean twist over the stretch
    (:func:`_judged_twist`)."""
    idx = [rec.body_names.index(b) for b in exp.bodies]
    times = rec.times[mask]
    poses = rec.poses[mask][:, idx]
    factor = exp.velocity_factor
    steps_of = np.zeros(len(exp.modes), dtype=int)
    for o, t in zip(judged, times):
        for k in matcher.matches(o, t):
            steps_of[k] += 1
    errors = [float(twist_error(q_obs, m.qdot * factor, th.length_scale, exp.drive))
              for m in exp.modes]
    ref_k = int(np.argmax(steps_of)) if steps_of.max() > 0 else int(np.argmin(errors))
    ref = exp.modes[ref_k]
    q_ref = np.asarray(ref.qdot, dtype=float) * factor
    e_twist = errors[ref_k]
    w = np.tile([1.0, 1.0, th.length_scale], len(idx))
    a, b = q_obs * w, q_ref * w
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    cosine = float(a @ b / (na * nb)) if na > 0 and nb > 0 else None
    outcome = base.outcome
    reasons = list(base.reasons)
    reasons.append(f"workpiece twist {np.round(q_obs, 8).tolist()} vs {ref.label}'s "
                   f"{np.round(q_ref, 8).tolist()}: error {e_twist:.1%} of "
                   f"max(|qdot|, drive) (allowed {TWIST_TOLERANCE:.0%})")
    if outcome is Outcome.AGREED and not e_twist <= TWIST_TOLERANCE:
        outcome = Outcome.DISAGREED
    # forces: the steps in the reference mode within the early stretch
    # the mode itself: not while a contact it opens is still clearing its depth
    in_ref = np.array([ref_k in matcher.matches(o, t, clear=False)
                       for o, t in zip(judged, times)], dtype=bool)
    # forces: over the first ``early`` seconds, nearest the certificate's configuration (a mean
    # of forces needs no long stretch; a pose difference resolves a twist only to depth / T)
    kf = int(np.flatnonzero(times <= float(times[0]) + th.early + 1e-12)[-1]) or len(times) - 1
    in_ref[kf + 1:] = False
    f_err = None
    forces: tuple[tuple[float, float], ...] = ()
    if in_ref.any() and (exp.system is not None or not ref.force_indeterminate):
        fn = np.where(rec.present, rec.normal_force, 0.0)[mask][in_ref].mean(axis=0)
        ft = np.where(rec.present, rec.tangent_force, 0.0)[mask][in_ref].mean(axis=0)
        c_obs = np.stack([fn, ft], axis=1)
        forces = tuple((float(c[0]), float(c[1])) for c in c_obs)
        fit = (nearest_certificate(exp.system, ref.mode, c_obs) if exp.system is not None
               else None)
        cert = fit.forces if fit is not None else np.asarray(ref.contact_forces, dtype=float)
        distance = fit.distance if fit is not None else float(np.max(np.abs(c_obs - cert)))
        # relative to the compared certificate's own size (never below the load): a rival's
        # large near-wedge forces must not loosen the check of a lightly loaded mode
        scale_f = certificate_scale(cert, exp.load) or exp.force_scale
        f_err = distance / scale_f
        drift = float(drift_from_start(poses[kf:kf + 1], rec.poses[0][idx],
                                       th.length_scale)[0])
        family = " (nearest member of its certificate family)" if ref.force_indeterminate else ""
        reasons.append(f"contact forces off the certificate{family} by up to {f_err:.1%} of its "
                       f"force scale {scale_f:.3g} N (allowed {FORCE_TOLERANCE:.0%})")
        if drift > FORCE_DRIFT_LIMIT:
            reasons.append(f"forces not judged: the workpiece had moved {drift:.1%} of its "
                           f"size from the configuration of the certificate (limit "
                           f"{FORCE_DRIFT_LIMIT:.0%})")
        elif outcome is Outcome.AGREED and not f_err <= FORCE_TOLERANCE:
            flicker = flicker_fraction(rec, th, mask)
            if flicker > 1.0 - MODE_FRACTION_REQUIRED:
                outcome = Outcome.INCONCLUSIVE
                reasons.append(f"forces not judged: the contacts flicker (per-step labels "
                               f"differ from the window label on {flicker:.0%} of the steps)")
            else:
                outcome = Outcome.DISAGREED
    clear = matcher.clear_until[ref_k] if matcher.clear_until is not None else np.array([])
    late = [f"{i + 1} until {clear[i]:.3g} s" for i in np.flatnonzero(clear > times[0])]
    if late:
        reasons.append(f"contacts {ref.label} opens, judged open once the predicted motion has "
                       f"lifted them out of their measured depth: {', '.join(late)}")
    if not in_ref.any() and steps_of[ref_k] > 0:
        reasons.append("forces not judged: no step of the stretch shows the mode itself (a "
                       "contact it opens is still clearing its depth)")
    motion = MotionMeasures(tuple(float(x) for x in q_obs), ref.label,
                            tuple(float(x) for x in q_ref), e_twist, cosine,
                            na / nb if nb > 0 else None, f_err, forces)
    return replace(base, outcome=outcome, reasons=tuple(reasons), motion=motion)


def _engine_cannot_tell(verdict: Verdict, rec: Recording, exp: ModeSet, th: Thresholds,
                        mask: np.ndarray) -> Verdict:
    """A mode miss is ``inconclusive`` when the workpiece's mean twist over the judged steps
    (least-squares slope of the recorded poses) is within the twist tolerance of a predicted
    mode while contacts that mode keeps closed are missing on more than
    :data:`LOST_FRACTION` of the judged steps (stick-slip or chatter)."""
    if mask.sum() < 3:
        return verdict
    idx = [rec.body_names.index(b) for b in exp.bodies]
    pose = rec.poses[mask][:, idx].copy()
    pose[:, :, 2] = np.unwrap(pose[:, :, 2], axis=0)
    slope = np.polyfit(rec.times[mask], pose.reshape(len(pose), -1), 1)[0]
    errors = [float(twist_error(slope, m.qdot * exp.velocity_factor, th.length_scale,
                                exp.drive)) for m in exp.modes]
    nearest = exp.modes[int(np.argmin(errors))]
    kept = np.array([c != BREAK for c in nearest.mode.codes], dtype=bool)
    if not kept.any():
        return verdict
    lost = float(np.mean(~rec.present[mask][:, kept]))
    if min(errors) > TWIST_TOLERANCE or lost <= LOST_FRACTION:
        return verdict
    return replace(verdict, outcome=Outcome.INCONCLUSIVE, reasons=verdict.reasons + (
        f"the workpiece's mean twist is within {min(errors):.1%} of {nearest.label}'s but "
        f"contacts are missing on {lost:.1%} of the judged steps (stick-slip or chatter): "
        "this engine cannot resolve the contact modes here",))


def _moved_by_correction(verdict: Verdict, rec: Recording, exp: ModeSet, th: Thresholds,
                         mask: np.ndarray, judged: Sequence[ObservedMode]) -> Verdict:
    """A disagreement is ``inconclusive`` when the engine moved a workpiece by position
    correction rather than by its velocities (:func:`sim.classify.correction_steps`) on more
    than ``1 - MODE_FRACTION_REQUIRED`` of the judged steps that were read as a contact mode
    (``judged``: the observed mode of each judged step; a step read as a jam showed the forces
    or penetration of one, which the engine does measure): the motion seen there is the
    engine's overlap removal, which carries no friction (docs/simulation.md, "Engine limits"),
    so the run can confirm neither the prediction nor a rival."""
    if verdict.outcome is not Outcome.DISAGREED:
        return verdict
    read_as_mode = np.array([o != JAM for o in judged], dtype=bool)
    steps = correction_steps(rec, th, exp.bodies)[mask] & read_as_mode
    share = float(np.mean(steps)) if len(steps) else 0.0
    if share <= 1.0 - MODE_FRACTION_REQUIRED:
        return verdict
    return replace(verdict, outcome=Outcome.INCONCLUSIVE, reasons=verdict.reasons + (
        f"the engine moved the workpiece by position correction, not by its velocities, on "
        f"{share:.1%} of the judged steps (overlap the drive made and the engine removed "
        f"without friction, faster than {th.jam_depth_rate:.3g} m/s): this engine cannot "
        "judge this run",))
