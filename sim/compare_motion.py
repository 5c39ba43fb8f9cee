"""The workpiece's motion and contact forces of a paper-example run against the certificate of
the predicted mode (``qdot``, ``contact_forces``; eqs. 2-5), on top of the mode comparison;
tolerances derived in docs/simulation.md ("Observed-mode classifier")."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from planner.predict.stages import FeasibleMode
from sim.compare import (
    FORCE_DRIFT_LIMIT,
    FORCE_TOLERANCE,
    JAM,
    MODE_FRACTION_REQUIRED,
    TWIST_TOLERANCE,
    MotionMeasures,
    ObservedMode,
    Outcome,
    Verdict,
    compare_modes,
)


def _weighted(q: np.ndarray, length_scale: float) -> np.ndarray:
    return np.asarray(q, dtype=float) * np.array([1.0, 1.0, length_scale])


def compare_motion(
    observed: Sequence[ObservedMode],
    predicted: Sequence[FeasibleMode],
    times: np.ndarray,
    poses: np.ndarray,
    normal_force: np.ndarray,
    tangent_force: np.ndarray,
    *,
    length_scale: float,
    load: float,
    early: float = 0.2,
    initial_pose: np.ndarray | None = None,
    flicker: float = 0.0,
    required: float = MODE_FRACTION_REQUIRED,
    twist_tolerance: float = TWIST_TOLERANCE,
    force_tolerance: float = FORCE_TOLERANCE,
) -> Verdict:
    """Judge the judged steps of a run against the planner's feasible modes (empty: a
    predicted jam): the modes (:func:`compare_modes`), then the workpiece's mean twist against
    the reference mode's ``qdot`` and, where that mode is force-determinate, the mean contact
    forces against its certificate (``contact_forces``, eq. 2's ``c``).

    ``times`` (m,) [s], ``poses`` (m, 3) workpiece poses, ``normal_force`` / ``tangent_force``
    (m, n_c) [N] (zero while a pair does not touch) of the judged steps; ``length_scale`` [m]
    weights rotation; ``load`` [N] scales force errors. The certificate (``qdot``, forces)
    holds at the initial configuration, so both are compared over the first ``early`` seconds
    of judged steps (the twist from the poses at its ends, the forces averaged over the steps
    in the reference mode); later the configuration drifts away from it. The forces are judged
    only when the pose at the end of that stretch is within :data:`FORCE_DRIFT_LIMIT` of the
    body size from ``initial_pose`` (3,) (default: the first judged pose), else reported.
    ``flicker``: fraction of judged steps whose per-step label differs from the window label
    (the worst contact).

    An agreement in modes with the twist off its tolerance is ``disagreed``; with the forces
    off, ``disagreed`` too unless the contacts flicker on more than ``1 - required`` of the
    steps: then the force check cannot hold in that engine and the verdict is ``inconclusive``
    with the measured cause.
    """
    modes: list[ObservedMode] = [m.mode for m in predicted]
    base = compare_modes(observed, modes or [JAM], required)
    if base.outcome is Outcome.INCONCLUSIVE or not predicted or len(times) < 2:
        return base
    pose = np.asarray(poses, dtype=float).copy()
    pose[:, 2] = np.unwrap(pose[:, 2])
    times = np.asarray(times, dtype=float)
    first = times <= float(times[0]) + early + 1e-12
    k1 = int(np.flatnonzero(first)[-1])
    q_obs = (pose[k1] - pose[0]) / float(times[k1] - times[0]) if k1 > 0 else \
        (pose[-1] - pose[0]) / float(times[-1] - times[0])
    labels = dict(base.observed_counts)
    seen = sorted((m for m in predicted if labels.get(m.mode.label, 0) > 0),
                  key=lambda m: -labels[m.mode.label])

    def err(m: FeasibleMode) -> float:
        size = float(np.linalg.norm(_weighted(m.qdot, length_scale)))
        diff = float(np.linalg.norm(_weighted(q_obs - m.qdot, length_scale)))
        return diff / size if size > 0 else (np.inf if diff > 0 else 0.0)

    ref = seen[0] if seen else min(predicted, key=err)
    a, b = _weighted(q_obs, length_scale), _weighted(ref.qdot, length_scale)
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    cosine = float(a @ b / (na * nb)) if na > 0 and nb > 0 else None
    e_twist = err(ref)
    reasons = list(base.reasons)
    outcome: Outcome = base.outcome
    reasons.append(f"workpiece twist {np.round(q_obs, 8).tolist()} vs {ref.mode.label}'s "
                   f"qdot {np.round(ref.qdot, 8).tolist()}: relative error {e_twist:.1%} "
                   f"(allowed {twist_tolerance:.0%})")
    if outcome is Outcome.AGREED and not e_twist <= twist_tolerance:
        outcome = Outcome.DISAGREED
    f_err = None
    forces: tuple[tuple[float, float], ...] = ()
    in_ref = np.array([o == ref.mode for o in observed], dtype=bool)
    in_ref &= first
    if not ref.force_indeterminate and in_ref.any():
        c_obs = np.stack([np.asarray(normal_force)[in_ref].mean(axis=0),
                          np.asarray(tangent_force)[in_ref].mean(axis=0)], axis=1)
        forces = tuple((float(c[0]), float(c[1])) for c in c_obs)
        f_err = float(np.max(np.linalg.norm(c_obs - np.asarray(ref.contact_forces), axis=1))
                      / load)
        p0 = pose[0] if initial_pose is None else np.asarray(initial_pose, dtype=float)
        drift = float(np.linalg.norm(_weighted(pose[k1] - p0, length_scale))) / length_scale
        reasons.append(f"contact forces off the certificate by up to {f_err:.1%} of the force "
                       "scale "
                       f"(allowed {force_tolerance:.0%})")
        if drift > FORCE_DRIFT_LIMIT:
            reasons.append(f"forces not judged: the workpiece had moved {drift:.1%} of its "
                           f"size from the configuration of the certificate (limit "
                           f"{FORCE_DRIFT_LIMIT:.0%})")
        elif outcome is Outcome.AGREED and not f_err <= force_tolerance:
            if flicker > 1.0 - required:
                outcome = Outcome.INCONCLUSIVE
                reasons.append(f"forces not judged: the contacts flicker (per-step labels differ "
                               f"from the window label on {flicker:.0%} of the steps)")
            else:
                outcome = Outcome.DISAGREED
    motion = MotionMeasures((float(q_obs[0]), float(q_obs[1]), float(q_obs[2])),
                            ref.mode.label,
                            (float(ref.qdot[0]), float(ref.qdot[1]), float(ref.qdot[2])),
                            e_twist, cosine, na / nb if nb > 0 else None, f_err, forces)
    return Verdict(outcome, tuple(reasons), agreement=base.agreement,
                   judged_steps=base.judged_steps, observed_counts=base.observed_counts,
                   motion=motion)
