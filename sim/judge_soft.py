"""Soft contacts in the judge: how long a contact the predicted mode opens may still read
loaded (:func:`clearing_times`), from the run's measured depths, the engine's recorded contact
points and the certificate's twists (docs/simulation.md, "Judging a run", Modes).

A rigid contact opens the instant the motion starts; a soft one (MuJoCo) is sunk by its
penetration and stays loaded until the predicted motion has lifted it out of it. How fast it
rises is the predicted relative normal velocity (eq. 5) **at the point where the engine's bodies
touch** (:func:`opening_speeds`): the depth is measured there, and a scene's surface that is a
segment rather than the model's point (``sim.scenes.shapes.ENV_INSET``: a support's flat top
reaches under the workpiece on each side) touches a tipping box at its end nearer the pivot,
where the box rises slower than at the model's contact point.

And the force scale a certificate is judged on (:func:`certificate_scale`), and how much load a
closed contact read unloaded may carry in it (:func:`unload_allowance`): an engine may leave a
lightly loaded contact unloaded.
"""

from __future__ import annotations

import numpy as np

from planner.model.modes import BREAK
from planner.predict.stages import FeasibleMode
from sim.classify import Thresholds
from sim.expectation import ModeSet
from sim.run import Recording
from sim.verdict import FORCE_TOLERANCE


def opening_speeds(rec: Recording, exp: ModeSet, k: int) -> np.ndarray:
    """(n_modes, n_c) [m/s]: each predicted mode's relative normal velocity of each contact
    (eq. 5's normal row, ``n_i . (v_a(p) - v_b(p))``, times the speed factor; positive: opening)
    at the point ``p`` where the engine recorded the contact at step ``k`` (world frame).

    The certificate gives it at the model's contact point ``r_i``; moving it to ``p`` adds
    ``n_i . ((omega_a - omega_b) z x (p - r_i))`` -- the bodies' predicted angular rates
    (``qdot``; the fixed environment's is zero), ``r_i`` carried with body ``a_i``'s recorded pose
    at step ``k`` and ``n_i`` turned with it. Kept at ``r_i``: a contact with the manipulator (the
    scene's fingertip is round and touches at the model's point; a chain link's angular rate is
    not a workpiece twist), a contact the recording has no finite point for at step ``k``
    (absent, or a recording made without contact points), and every contact of a system
    without contact geometry."""
    n_c = rec.present.shape[1]
    out = np.zeros((len(exp.modes), n_c))
    s = exp.system
    for m_k, m in enumerate(exp.modes):
        if len(m.mode.codes) == n_c:
            out[m_k] = np.asarray(m.contact_velocities, dtype=float)[:, 0] * exp.velocity_factor
    if s is None or s.points is None or s.normals is None or len(s.points) != n_c:
        return out
    env = tuple(s.environment)
    bodies = tuple(s.contact_bodies) or ((0, -1),) * n_c
    points = np.asarray(s.points, dtype=np.float64)
    normals = np.asarray(s.normals, dtype=np.float64)
    for m_k, m in enumerate(exp.modes):
        if len(m.mode.codes) != n_c:
            continue
        q = np.asarray(m.qdot, dtype=float).reshape(-1, 3) * exp.velocity_factor
        for i in range(n_c):
            a, b = bodies[i]
            p = np.asarray(rec.points[k, i], dtype=float)
            fixed_other = b < 0 and len(env) == n_c and env[i]
            if not (b >= 0 or fixed_other) or not np.all(np.isfinite(p)):
                continue
            x, y, theta = rec.poses[k, rec.body_names.index(exp.bodies[a])]
            c, sn = np.cos(theta), np.sin(theta)
            rot = np.array([[c, -sn], [sn, c]])
            r = rot @ points[i] + np.array([x, y])
            n = rot @ normals[i]
            w = q[a, 2] - (q[b, 2] if b >= 0 else 0.0)
            d = p - r
            out[m_k, i] += w * (n[1] * d[0] - n[0] * d[1])  # n . (w z x d)
    return out


def clearing_times(rec: Recording, exp: ModeSet, th: Thresholds, mask: np.ndarray
                   ) -> np.ndarray:
    """(n_modes, n_c) [s]: run time until which each contact a predicted mode opens may still
    read loaded (``-inf``: judged open from the first judged step).

    A contact the mode opens at the predicted normal speed ``v_n > 0`` at the engine's contact
    point (:func:`opening_speeds`) that the engine shows sunk by ``depth`` at the first judged
    step ``t_0`` opens at ``t_0 + (depth + sink) / v_n``, where ``sink`` is how much deeper the
    contacts the mode keeps closed sink during the judged steps (measured: a pivot sinks
    further as it takes over the load, and the body with it). A box tipping at ``omega`` lifts
    a support touching it at ``d`` from its pivot at ``v_n = omega d``: it opens after the turn
    ``(depth + sink) / d``. The classifier's centred window reads it open half a window later.
    A contact whose engine point does not rise under the predicted motion (``v_n <= 0``) or
    that shows no depth is never excused. Depths are each engine's own measurements: pymunk
    holds resting contacts about half its collision slop deep (5e-5 of the scene size),
    MuJoCo's soft ones sink 1e-5 to 1e-3 of it (docs/simulation.md, "Judging a run")."""
    n_c = rec.present.shape[1]
    out = np.full((len(exp.modes), n_c), -np.inf)
    if not mask.any():
        return out
    k0 = int(np.flatnonzero(mask)[0])
    t0 = float(rec.times[k0])
    depth = np.where(rec.present, np.maximum(rec.depth, 0.0), 0.0)
    later = depth[mask] - depth[k0]  # (judged steps, n_c) sinking since t0
    speeds = opening_speeds(rec, exp, k0)
    for k, m in enumerate(exp.modes):
        if len(m.mode.codes) != n_c:
            continue
        vn = speeds[k]
        breaks = np.array([c == BREAK for c in m.mode.codes], dtype=bool)
        opens = breaks & (vn > 0) & (depth[k0] > 0)
        if not opens.any():
            continue
        kept = ~breaks & rec.present[k0]
        sink = max(0.0, float(later[:, kept].max())) if kept.any() else 0.0
        out[k, opens] = t0 + (depth[k0, opens] + sink) / vn[opens] + 0.5 * th.window
    return out


def stretch_readings(exp: ModeSet, q_obs: np.ndarray, slip_speed: float) -> np.ndarray:
    """(n_modes, n_c) bool: whether each contact's **relative motion over the stretch** reads as
    the mode's token there -- ``R`` when ``|v_t| <= slip_speed`` [m/s], ``S+`` / ``S-`` beyond
    it (the classifier's threshold, :class:`sim.classify.Thresholds`); never for ``B``.

    ``v_t`` is eq. 5's tangential row with the workpieces' twist measured over the stretch
    ``q_obs`` (3 n_b,) (:func:`sim.judge.twist_stretch`) in place of the prediction's: ``v =
    W^T q_obs - J thetadot``, i.e. the certificate's contact velocity (times the speed factor)
    plus ``W^T (q_obs - q_pred)`` -- the manipulator moves as commanded. It is the relative
    motion of the contact's two bodies over the stretch, which a soft contact's elastic give
    cannot fake: a contact's tangential spring-back is bounded by its deformation ``x``, so it
    adds at most ``2 x / T`` to a mean slip over ``T``, while the classifier's per-step window
    (0.1 s) resolves only ``2 x / 0.1 s`` (docs/simulation.md, "Judging a run")."""
    if exp.system is None:
        raise ValueError("stretch_readings: expected an expectation with its system, got none")
    out = np.zeros((len(exp.modes), exp.system.n_contacts), dtype=bool)
    W = np.asarray(exp.system.W, dtype=float)
    for k, m in enumerate(exp.modes):
        q_pred = np.asarray(m.qdot, dtype=float) * exp.velocity_factor
        v_t = (np.asarray(m.contact_velocities, dtype=float)[:, 1] * exp.velocity_factor
               + (W.T @ (np.asarray(q_obs, dtype=float) - q_pred))[1::2])
        read = np.where(v_t > slip_speed, "S+", np.where(v_t < -slip_speed, "S-", "R"))
        out[k] = [tok != "B" and tok == r for tok, r in zip(m.mode.tokens, read)]
    return out


def contact_sink(rec: Recording) -> float:
    """[m] the deepest a contact of ``rec`` sank into its surface while touching (0 when none
    did): a rigid model's positions are realized only to within it, since the workpiece sits
    that much deeper in the surfaces that hold it (docs/simulation.md, "Judging a run")."""
    depth = np.nan_to_num(np.asarray(rec.depth, dtype=float))
    return float(np.max(np.where(np.asarray(rec.present, dtype=bool), depth, 0.0), initial=0.0))


def unexplained_reach(rec: Recording, exp: ModeSet, length: float) -> np.ndarray:
    """(T,) [m]: how far the workpieces have moved from their first recorded poses **beyond what
    their contacts' sinking explains** -- the largest over the workpieces of the displacement
    (rotation times ``length`` [m]) left when the smallest displacement that accounts for the
    measured depth changes is taken away.

    A small displacement ``d`` (3 n_b,: each workpiece's frame origin and angle) changes contact
    ``i``'s normal gap by eq. 5's normal row, ``(W^T d)_n`` (positive: opening), and slides it by
    the tangential row ``(W^T d)_t``. A contact that a soft (or slop-holding) engine sinks deeper
    by ``delta_i`` since the first step closes its gap by ``delta_i``, and one whose friction
    holds (``mu_used > 0`` at both steps) does not slide, so of the displacement ``D d`` (``D``:
    ``length`` on the angles) the part the sinking explains is ``e = (M D^-1)^+ (-delta, 0)``,
    ``M`` the normal rows of the contacts recorded at both steps and the tangential rows of
    those with friction (least squares where they outnumber the coordinates), and ``|D d - e|``
    is the rest: a workpiece that only settles into its contacts gives 0 (up to the
    linearization, second order in the sink), one that slides along them, turns about one of
    them or loses one gives the motion itself. ``W`` is the system's at its start
    configuration. Without a system with ``W`` it is the plain displacement
    (docs/simulation.md, "Static questions")."""
    idx = [rec.body_names.index(b) for b in exp.bodies]
    pose = rec.poses[:, idx].copy()
    pose[:, :, 2] = np.unwrap(pose[:, :, 2], axis=0)
    scale = np.array([1.0, 1.0, length])
    dw = ((pose - pose[0]) * scale).reshape(len(rec.times), -1)  # (T, 3 n_b) weighted
    n_b = len(idx)
    s = exp.system
    W = None if s is None else getattr(s, "W", None)
    if W is None or np.asarray(W).shape != (3 * n_b, 2 * rec.present.shape[1]):
        return np.max(np.linalg.norm(dw.reshape(len(rec.times), n_b, 3), axis=2), axis=1)
    Wt = np.asarray(W, dtype=float).T / np.tile(scale, n_b)  # rows in weighted coords
    normal, tangent = Wt[0::2], Wt[1::2]
    depth = np.where(rec.present, rec.depth, np.nan)
    mu = np.nan_to_num(np.asarray(rec.mu_used, dtype=float))
    out = np.empty(len(rec.times))
    for k in range(len(rec.times)):
        rows = np.isfinite(depth[k]) & np.isfinite(depth[0])
        rest = dw[k]
        held = rows & (mu[k] > 0) & (mu[0] > 0)
        if rows.any():
            M = np.vstack([normal[rows], tangent[held]])
            rhs = np.concatenate([depth[0, rows] - depth[k, rows], np.zeros(int(held.sum()))])
            rest = rest - np.linalg.pinv(M) @ rhs
        out[k] = np.max(np.linalg.norm(rest.reshape(n_b, 3), axis=1))
    return out


def certificate_scale(forces: np.ndarray, load: float) -> float:
    """The force scale [N] contact forces are judged against for a certificate ``forces``
    ``(n_c, 2)`` [N] (``(c_in, c_it)``): the larger of ``load`` [N] and its total normal force
    (:mod:`sim.judge`, 3) -- the certificate's own size, so a rival's large near-wedge forces do
    not loosen the check of a lightly loaded mode."""
    return max(load, float(np.sum(np.maximum(np.asarray(forces, dtype=float)[:, 0], 0.0))))


def unload_allowance(mode: FeasibleMode, load: float) -> float:
    """The normal force [N] a closed contact of ``mode`` may carry in a member of its certificate
    family and still read as carrying none (``B``): :data:`~sim.verdict.FORCE_TOLERANCE` of the
    certificate's force scale (:func:`certificate_scale`) -- the force check's own allowance
    (:mod:`sim.judge`, 3), so a run the force check accepts is not refused by its mode for a
    lightly loaded contact the engine leaves unloaded."""
    return FORCE_TOLERANCE * certificate_scale(mode.contact_forces, load)
