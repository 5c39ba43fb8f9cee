"""Observed contact modes from simulator contact data only (judged in :mod:`sim.judge`).

Per contact and recorded step (``docs/conventions.md`` mode tokens), from the contact's signals
averaged over a centred window of ``window`` seconds (:func:`window_mean`):

* ``B`` when the mean normal force (zero while the pair does not touch) is below
  ``force_floor``;
* ``S+`` / ``S-`` when the mean relative tangential velocity ``v_t`` (workpiece minus finger,
  eq. 5; over the steps the pair touches) exceeds ``+slip_speed`` / is below ``-slip_speed``;
* ``R`` otherwise.

Hysteresis (:func:`window_tokens`): a contact leaves ``S`` only when ``|mean v_t|`` falls below
``slip_speed / 2`` and leaves ``B`` only when the mean force exceeds ``2 force_floor``, so a
mean that hovers at a threshold does not chatter. A window mean cannot be frozen by flicker: a
contact that slides on 60 % of its steps and reads rolling or broken on the rest has the mean
slip of its sliding steps times 0.6 (a debounce that restarts its timer on every repeat of
the current label would keep such a contact in its first label for ever).

Thresholds (:class:`Thresholds`; derived in docs/simulation.md, "Observed-mode classifier"):
``slip_speed = max(0.05 * drive_speed, 10 * creep_floor)``; ``force_floor = 1e-3 * |load|``;
``window = 0.1 s``.

Observed jam (``JAM``, Fig. 3 "Jam": no quasistatic motion): a step is ``JAM`` only when the
workpiece stops following every predicted twist (:func:`twist_error` above
``jam_twist_error`` for each predicted ``qdot``; vacuous when nothing is predicted) *and* the
contact forces grow: the window-mean total normal force exceeds ``jam_force``, or the summed
penetration depth of the contacts touching throughout the trailing ``jam_rate_window`` grows
faster than ``jam_depth_rate`` (soft engines yield instead of blowing up). A body that moves as
predicted while the forces build up and level off is not jammed.

Motion by position correction (:func:`correction_steps`): an engine that removes overlap
outside its velocity solve turns penetration it could not prevent into motion, without
friction. Such steps show neither the predicted mode nor a jam; the judge reports a run
dominated by them as one the engine cannot judge (:mod:`sim.judge`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from planner.model.modes import BREAK, ROLL, SLIDE, Mode
from sim.run import Recording
from sim.verdict import JAM, ObservedMode

#: Per-contact token -> (mode code, sliding direction xi) of :class:`planner.model.modes.Mode`.
TOKEN_CODES = {"R": (ROLL, 0), "S+": (SLIDE, 1), "S-": (SLIDE, -1), "B": (BREAK, 0)}


@dataclass(frozen=True)
class Thresholds:
    """``slip_speed`` [m/s]; ``force_floor`` [N]; ``window`` [s] centred averaging window;
    ``settle`` [s] (steps before it are never judged); ``jam_force`` [N] total normal force
    (None: no force rule); ``jam_depth_rate`` [m/s] and ``jam_rate_window`` [s] (penetration
    growth rule); ``jam_twist_error``: relative twist error above which the workpiece no longer
    follows a predicted twist; ``jam_depth_force`` [N]: the depth-growth rule counts only
    where the window-mean total normal force also rose by more than this over the trailing
    ``jam_rate_window`` (0: always; system runs set the run's force scale: a soft contact's
    depth creeping under steady forces is no jam -- MuJoCo's Example 4.3 at mu = .80 .72 .83
    moved as ``R1 B2 S-3`` on every step and was read as a jam); ``length_scale`` [m] weights
    rotation in twist errors; ``load`` [N] the force scale (scales force errors); ``early``
    [s] the shortest stretch at the start of the judged steps over which twist and forces are
    compared with the certificate (:func:`sim.judge.twist_stretch`); ``drive`` [m/s] the
    fastest commanded contact speed (the floor of twist errors, :func:`twist_error`)."""

    slip_speed: float
    force_floor: float
    window: float = 0.1
    settle: float = 0.2
    jam_force: float | None = None
    jam_depth_rate: float = np.inf
    jam_rate_window: float = 1.0
    jam_twist_error: float = 0.5
    jam_depth_force: float = 0.0
    length_scale: float = 1.0
    load: float = 1.0
    early: float = 0.2
    drive: float = 0.0

    @classmethod
    def for_drive(cls, drive_speed: float, load: float, creep_floor: float = 1e-8,
                  settle: float = 0.2, jam_force: float | None = None,
                  length_scale: float = 1.0) -> Thresholds:
        """Thresholds from the drive speed [m/s], load [N] and the engine's creep floor
        [m/s]; the jam depth rate is 1 % of the drive speed."""
        return cls(slip_speed=max(0.05 * drive_speed, 10.0 * creep_floor),
                   force_floor=1e-3 * load, settle=settle, jam_force=jam_force,
                   jam_depth_rate=max(0.01 * drive_speed, 10.0 * creep_floor),
                   length_scale=length_scale, load=load, drive=drive_speed)


def window_mean(values: np.ndarray, weights: np.ndarray, times: np.ndarray,
                window: float) -> np.ndarray:
    """Centred moving average of ``values`` (T, ...) weighted by ``weights`` (same shape, 0/1
    or positive) over ``window`` seconds; NaN where the window holds no weight. Assumes evenly
    recorded steps (as :func:`sim.run.run_scene` records)."""
    T = len(times)
    if T == 0:
        return np.zeros_like(values, dtype=float)
    step = float(times[1] - times[0]) if T > 1 else window
    h = max(0, int(round(0.5 * window / step)))
    v = np.where(weights > 0, values * weights, 0.0)
    w = np.asarray(weights, dtype=float)
    pad = ((1, 0),) + ((0, 0),) * (v.ndim - 1)
    cv = np.pad(np.cumsum(v, axis=0), pad)
    cw = np.pad(np.cumsum(w, axis=0), pad)
    lo = np.clip(np.arange(T) - h, 0, T)
    hi = np.clip(np.arange(T) + h + 1, 0, T)
    num, den = cv[hi] - cv[lo], cw[hi] - cw[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)


def raw_tokens(rec: Recording, th: Thresholds) -> np.ndarray:
    """(T, P) per-step tokens ``R``, ``S+``, ``S-``, ``B`` without any averaging (diagnostics
    and the flicker statistics of docs/simulation.md)."""
    tok = np.full(rec.present.shape, "R", dtype=object)
    tok[rec.slip_velocity > th.slip_speed] = "S+"
    tok[rec.slip_velocity < -th.slip_speed] = "S-"
    tok[~rec.present | (rec.normal_force < th.force_floor)] = "B"
    return tok


def window_tokens(rec: Recording, th: Thresholds) -> np.ndarray:
    """(T, P) tokens from window means with hysteresis (module docstring)."""
    present = rec.present.astype(float)
    force = window_mean(np.where(rec.present, rec.normal_force, 0.0), np.ones_like(present),
                        rec.times, th.window)
    slip = window_mean(rec.slip_velocity, present, rec.times, th.window)
    T, P = present.shape
    out = np.empty((T, P), dtype=object)
    for j in range(P):
        state = "R"
        for k in range(T):
            f, v = force[k, j], slip[k, j]
            if state == "B":
                broken = not f > 2.0 * th.force_floor
            else:
                broken = not f >= th.force_floor
            if broken or not np.isfinite(v):
                state = "B"
            elif v > th.slip_speed or (state == "S+" and v > 0.5 * th.slip_speed):
                state = "S+"
            elif v < -th.slip_speed or (state == "S-" and v < -0.5 * th.slip_speed):
                state = "S-"
            else:
                state = "R"
            out[k, j] = state
    return out


def mode_of(tokens: tuple[str, ...]) -> Mode:
    """The :class:`Mode` of one row of per-contact tokens (``R``, ``S+``, ``S-``, ``B``)."""
    pairs = [TOKEN_CODES[t] for t in tokens]
    return Mode(tuple(c for c, _ in pairs), tuple(x for _, x in pairs))


def workpiece_twist(rec: Recording, window: float,
                    bodies: tuple[str, ...] = ("workpiece",)) -> np.ndarray:
    """(T, 3 n_b) twists ``(v_x, v_y, omega)`` [m/s, m/s, rad/s] of the ``bodies``' frame
    origins (the workpieces, in the system's order), central differences of the recorded poses
    averaged over ``window`` seconds."""
    idx = [rec.body_names.index(b) for b in bodies]
    pose = rec.poses[:, idx].copy()  # (T, n_b, 3)
    if len(pose) < 2:
        return np.zeros((len(pose), 3 * len(idx)))
    pose[:, :, 2] = np.unwrap(pose[:, :, 2], axis=0)
    q = np.gradient(pose, rec.times, axis=0).reshape(len(pose), -1)
    return window_mean(q, np.ones_like(q), rec.times, window)


def twist_error(observed: np.ndarray, predicted: np.ndarray, length_scale: float,
                floor: float = 0.0) -> np.ndarray:
    """Error of observed twists against a predicted one, ``max_b |q_obs,b - q_pred,b|_L /
    max(|q_pred|_L, floor)`` with ``|(v_x, v_y, w)|_L = sqrt(v_x^2 + v_y^2 + (L w)^2)``
    (``L = length_scale`` [m]) per body ``b``; ``observed`` (..., 3 n_b), ``predicted``
    (3 n_b,). ``floor`` [m/s] (the drive speed: docs/simulation.md, "Twist and forces") makes
    the error absolute where the predicted twist is slower than it -- a predicted rest included;
    with ``floor`` 0 a zero predicted twist gives ``inf`` for any motion."""
    pred = np.asarray(predicted, dtype=float)
    nb = pred.size // 3
    wvec = np.array([1.0, 1.0, length_scale])
    obs = np.asarray(observed, dtype=float)
    diff = np.linalg.norm(((obs - pred).reshape(*obs.shape[:-1], nb, 3)) * wvec, axis=-1)
    diff = np.max(diff, axis=-1)
    size = max(float(np.linalg.norm(pred.reshape(nb, 3) * wvec)), float(floor))
    return diff / size if size > 0 else np.where(diff > 0, np.inf, 0.0)


def correction_steps(rec: Recording, th: Thresholds,
                     bodies: tuple[str, ...] = ("workpiece",)) -> np.ndarray:
    """(T,) bool: steps at which a workpiece is moved by position correction rather than by
    its velocities (docs/simulation.md, "Observed-mode classifier").

    ``rec.correction`` (:class:`sim.run.Recording`) is the displacement the engine gave a body
    beyond ``twist * dt``.  Its rate, averaged over the centred ``th.window``, is a speed of
    hidden penetration growth: overlap the velocity solve let grow and the engine removed by
    pushing bodies apart -- frictionlessly in pymunk (Chipmunk's bias velocities carry no
    friction impulse).  A step counts when, for some workpiece, that rate exceeds the jam
    depth rate ``th.jam_depth_rate`` (the same growth the penetration rule of :func:`jam_steps`
    calls a jam) *and* half of the workpiece's own speed from its poses (more of its motion is
    correction than velocity).  Both speeds are ``|(v_x, v_y, w)|_L`` with ``L =
    th.length_scale``.  All False for recordings without ``correction``."""
    T = len(rec.times)
    if rec.correction is None or T < 3 or not np.isfinite(th.jam_depth_rate):
        return np.zeros(T, dtype=bool)
    idx = [rec.body_names.index(b) for b in bodies if b in rec.body_names]
    if not idx:
        return np.zeros(T, dtype=bool)
    corr = rec.correction[:, idx].reshape(T, -1)
    rate = window_mean(np.gradient(corr, rec.times, axis=0), np.ones_like(corr), rec.times,
                       th.window).reshape(T, len(idx), 3)
    speed = workpiece_twist(rec, th.window, tuple(rec.body_names[i] for i in idx))
    speed = speed.reshape(T, len(idx), 3)
    wvec = np.array([1.0, 1.0, th.length_scale])
    c = np.linalg.norm(np.nan_to_num(rate) * wvec, axis=-1)
    v = np.linalg.norm(np.nan_to_num(speed) * wvec, axis=-1)
    return np.any((c > th.jam_depth_rate) & (c > 0.5 * v), axis=1)


def jam_steps(rec: Recording, th: Thresholds,
              predicted_twists: Sequence[np.ndarray] = (),
              bodies: tuple[str, ...] = ("workpiece",)) -> np.ndarray:
    """(T,) bool: steps showing a jam (module docstring); ``predicted_twists`` (3 n_b,) of the
    ``bodies``."""
    T = len(rec.times)
    grows = np.zeros(T, dtype=bool)
    if T == 0:
        return grows
    if th.jam_force is not None:
        total = window_mean(np.sum(np.where(rec.present, rec.normal_force, 0.0), axis=1),
                            np.ones(T), rec.times, th.window)
        grows |= total > th.jam_force
    if T > 1 and np.isfinite(th.jam_depth_rate):
        step = float(rec.times[1] - rec.times[0])
        w = max(1, int(round(th.jam_rate_window / step)))
        if T > w:
            touching = np.ones((T - w, rec.present.shape[1]), dtype=bool)
            for lag in range(0, w + 1, max(1, w // 10)):
                touching &= rec.present[lag:T - w + lag]
            depth = np.where(rec.present, rec.depth, 0.0)
            grown = np.sum(np.where(touching, depth[w:] - depth[:-w], 0.0), axis=1)
            after_start = rec.times[:-w] >= max(0.0, th.settle - th.jam_rate_window) - 1e-12
            grows[w:] |= (after_start & touching.any(axis=1)
                          & (grown / (w * step) > th.jam_depth_rate))
            if th.jam_depth_force > 0:  # depth creeping under steady forces is no jam
                total = window_mean(np.sum(np.where(rec.present, rec.normal_force, 0.0),
                                           axis=1), np.ones(T), rec.times, th.window)
                rising = np.zeros(T, dtype=bool)
                rising[w:] = total[w:] - total[:-w] > th.jam_depth_force
                grows &= rising | (total > (th.jam_force or np.inf))
    if not predicted_twists or not grows.any():
        return grows
    q = workpiece_twist(rec, th.window, bodies)
    follows = np.zeros(T, dtype=bool)
    for qp in predicted_twists:
        follows |= twist_error(q, np.asarray(qp, dtype=float), th.length_scale, th.drive) \
            <= th.jam_twist_error
    return grows & ~follows


def observed_modes(rec: Recording, th: Thresholds,
                   predicted_twists: Sequence[np.ndarray] = (),
                   bodies: tuple[str, ...] = ("workpiece",)) -> list[ObservedMode]:
    """Observed :class:`Mode` per recorded step, or :data:`sim.verdict.JAM`
    (``predicted_twists`` of the workpieces ``bodies``: :func:`jam_steps`)."""
    tok = window_tokens(rec, th)
    cache: dict[tuple[str, ...], Mode] = {}
    modes = []
    for row in tok:
        key = tuple(row)
        if key not in cache:
            cache[key] = mode_of(key)
        modes.append(cache[key])
    jam = jam_steps(rec, th, predicted_twists, bodies)
    if rec.jammed_at is not None and np.any(jam):
        jam[int(np.flatnonzero(jam)[0]):] = True  # the run stopped on a sustained jam
    return [JAM if j else m for j, m in zip(jam, modes)]


def flicker_fraction(rec: Recording, th: Thresholds, mask: np.ndarray) -> float:
    """Largest fraction, over the contacts, of the ``mask`` steps whose per-step token
    (:func:`raw_tokens`) differs from the window token (:func:`window_tokens`)."""
    if not mask.any() or rec.present.shape[1] == 0:
        return 0.0
    differ = raw_tokens(rec, th)[mask] != window_tokens(rec, th)[mask]
    return float(np.max(np.mean(differ, axis=0)))


def judged_mask(rec: Recording, th: Thresholds) -> np.ndarray:
    """(T,) bool: the steps a comparison judges, those at or after ``th.settle`` (a run that
    stopped early has fewer; one that stopped before settling has none)."""
    return rec.times >= th.settle - 1e-12
