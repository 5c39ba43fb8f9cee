"""Observed contact modes from simulator contact data only, and their comparison with predictions.

Per contact and recorded step (``docs/conventions.md`` mode tokens):

* ``B`` when the pair is not touching or its normal force is below ``force_floor``;
* ``S+`` / ``S-`` when the relative tangential velocity ``v_t`` (workpiece minus finger, eq. 5)
  exceeds ``+slip_speed`` / is below ``-slip_speed``;
* ``R`` otherwise.

Thresholds (:class:`Thresholds`, justified in ``docs/simulation.md``): ``slip_speed =
max(0.05 * drive_speed, 10 * creep_floor)`` -- the slowest sliding contacts of eqs. (37)/(42)
slide at ~15 % of the drive speed, while pymunk sticks to ~1e-9 m/s and MuJoCo (elliptic cone,
noslip) to ~1e-8 m/s; ``force_floor = 1e-3 * |load|`` (SIM-NOTES).
Debounce: a contact's label changes only after the new raw label held for ``debounce``
seconds (50 ms), so single-step losses and start transients are not mode changes.

Observed jam (``JAM``, Fig. 3): the fingers keep pressing but cannot move the workpiece, so
force or penetration grows. A step is ``JAM`` when the total normal force exceeds ``jam_force``
(rigid engines: pymunk's forces blow up by orders of magnitude), or when the summed
penetration depth of the contacts touching throughout the trailing ``jam_rate_window`` grew
faster than ``jam_depth_rate`` (only windows starting at or after ``settle - jam_rate_window``,
i.e. after the start transient) (soft engines: MuJoCo's contacts yield, the depth creeps up
steadily). In a feasible mode the summed depth only follows the slowly changing quasistatic
force (single depths may see-saw when the workpiece rocks between two fingers).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from sim.run import Recording

JAM = "JAM"


@dataclass(frozen=True)
class Thresholds:
    """``slip_speed`` [m/s], ``force_floor`` [N], ``debounce`` [s], ``settle`` [s] (steps
    before ``settle`` are excluded from the agreement)."""

    slip_speed: float
    force_floor: float
    debounce: float = 0.05
    settle: float = 0.2
    jam_depth_rate: float = np.inf
    jam_rate_window: float = 1.0

    @classmethod
    def for_drive(cls, drive_speed: float, load: float, creep_floor: float = 1e-8,
                  settle: float = 0.2) -> Thresholds:
        """Thresholds from the drive speed [m/s], load [N] and the engine's creep floor; the
        jam depth rate is 1 % of the drive speed."""
        return cls(slip_speed=max(0.05 * drive_speed, 10.0 * creep_floor),
                   force_floor=1e-3 * load, settle=settle,
                   jam_depth_rate=max(0.01 * drive_speed, 10.0 * creep_floor))


def jam_steps(rec: Recording, th: Thresholds, jam_force: float | None) -> np.ndarray:
    """(T,) bool: steps showing a jam (growing force or penetration, module docstring)."""
    T = len(rec.times)
    out = np.zeros(T, dtype=bool)
    if jam_force is not None:
        out |= np.sum(np.where(rec.present, rec.normal_force, 0.0), axis=1) > jam_force
    if T > 1 and np.isfinite(th.jam_depth_rate):
        step = float(rec.times[1] - rec.times[0])
        w = max(1, int(round(th.jam_rate_window / step)))
        if T > w:
            touching = np.ones((T - w, rec.present.shape[1]), dtype=bool)
            for lag in range(0, w + 1, max(1, w // 10)):
                touching &= rec.present[lag:T - w + lag]
            depth = np.where(rec.present, rec.depth, 0.0)
            grown = np.sum(np.where(touching, depth[w:] - depth[:-w], 0.0), axis=1)
            # windows must start after the start transient: settle - window (>= 0)
            after_start = rec.times[:-w] >= max(0.0, th.settle - th.jam_rate_window) - 1e-12
            out[w:] |= (after_start & touching.any(axis=1)
                        & (grown / (w * step) > th.jam_depth_rate))
    return out


def raw_tokens(rec: Recording, th: Thresholds) -> np.ndarray:
    """(T, P) array of tokens ``R``, ``S+``, ``S-``, ``B`` before debouncing."""
    tok = np.full(rec.present.shape, "R", dtype=object)
    tok[rec.slip_velocity > th.slip_speed] = "S+"
    tok[rec.slip_velocity < -th.slip_speed] = "S-"
    tok[~rec.present | (rec.normal_force < th.force_floor)] = "B"
    return tok


def debounce(tokens: np.ndarray, times: np.ndarray, window: float) -> np.ndarray:
    """Hold each column's label until a new one persisted for ``window`` seconds."""
    out = tokens.copy()
    T, P = tokens.shape
    for j in range(P):
        current = tokens[0, j]
        cand, since = current, 0
        for k in range(T):
            raw = tokens[k, j]
            if raw == current:
                cand, since = current, k
            elif raw != cand:
                cand, since = raw, k
            if cand != current and times[k] - times[since] >= window - 1e-12:
                current = cand
                out[since:k + 1, j] = current
            out[k, j] = current
    return out


def observed_modes(rec: Recording, th: Thresholds, jam_force: float | None = None) -> list[str]:
    """Mode string per recorded step, e.g. ``"R1 S-2 B3"``, or ``"JAM"``."""
    tok = debounce(raw_tokens(rec, th), rec.times, th.debounce)
    labels = [" ".join(f"{t}{i + 1}" for i, t in enumerate(row)) for row in tok]
    jam = jam_steps(rec, th, jam_force)
    if rec.jammed_at is not None and np.any(jam):
        jam[int(np.flatnonzero(jam)[0]):] = True  # the run stopped on a sustained jam
    return [JAM if j else lab for j, lab in zip(jam, labels)]


class Outcome(str, Enum):
    """``AGREED``: agreement >= threshold; ``DISAGREED``: below; ``FAULT``: simulator trouble
    (the run says nothing about the prediction)."""

    AGREED = "agreed"
    DISAGREED = "disagreed"
    FAULT = "fault"


@dataclass(frozen=True)
class Comparison:
    outcome: Outcome
    agreement: float
    settled_steps: int
    observed_counts: dict[str, int]
    reason: str


def compare(rec: Recording, observed: list[str], predicted: list[str], th: Thresholds,
            required: float = 0.95) -> Comparison:
    """Fraction of settled steps whose observed mode is in ``predicted`` (``["JAM"]`` for a
    predicted jam). A fault, or a run without settled steps, is ``FAULT``."""
    settled = np.flatnonzero(rec.times >= th.settle)
    obs = [observed[k] for k in settled]
    if rec.jammed_at is not None and observed and observed[-1] == JAM:
        obs = [o for o in observed if o == JAM] if not obs else obs
    counts: dict[str, int] = {}
    for o in obs:
        counts[o] = counts.get(o, 0) + 1
    if rec.fault is not None:
        return Comparison(Outcome.FAULT, 0.0, len(obs), counts, rec.fault.reason)
    if not obs:
        return Comparison(Outcome.FAULT, 0.0, 0, counts, "no settled steps recorded")
    agree = float(np.mean([o in predicted for o in obs]))
    outcome = Outcome.AGREED if agree >= required else Outcome.DISAGREED
    return Comparison(outcome, agree, len(obs), counts,
                      f"{agree:.1%} of {len(obs)} settled steps in the predicted set")
