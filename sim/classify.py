"""Observed contact modes from simulator contact data only (compared in :mod:`sim.compare`).

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

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from planner.model.modes import BREAK, ROLL, SLIDE, Mode
from sim.compare import (
    JAM,
    MODE_FRACTION_REQUIRED,
    ObservedMode,
    Verdict,
    compare_modes,
    fault_verdict,
)
from sim.run import Recording

#: Per-contact token -> (mode code, sliding direction xi) of :class:`planner.model.modes.Mode`.
TOKEN_CODES = {"R": (ROLL, 0), "S+": (SLIDE, 1), "S-": (SLIDE, -1), "B": (BREAK, 0)}


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


def mode_of(tokens: tuple[str, ...]) -> Mode:
    """The :class:`Mode` of one row of per-contact tokens (``R``, ``S+``, ``S-``, ``B``)."""
    pairs = [TOKEN_CODES[t] for t in tokens]
    return Mode(tuple(c for c, _ in pairs), tuple(x for _, x in pairs))


def observed_modes(rec: Recording, th: Thresholds,
                   jam_force: float | None = None) -> list[ObservedMode]:
    """Observed :class:`Mode` per recorded step, or :data:`sim.compare.JAM`."""
    tok = debounce(raw_tokens(rec, th), rec.times, th.debounce)
    cache: dict[tuple[str, ...], Mode] = {}
    modes = []
    for row in tok:
        key = tuple(row)
        if key not in cache:
            cache[key] = mode_of(key)
        modes.append(cache[key])
    jam = jam_steps(rec, th, jam_force)
    if rec.jammed_at is not None and np.any(jam):
        jam[int(np.flatnonzero(jam)[0]):] = True  # the run stopped on a sustained jam
    return [JAM if j else m for j, m in zip(jam, modes)]


def judged_steps(rec: Recording, observed: list[ObservedMode],
                 th: Thresholds) -> list[ObservedMode]:
    """The observed modes of the steps a comparison judges: those after ``th.settle``; a run
    that stopped on a jam before settling is judged on its jam steps."""
    settled = np.flatnonzero(rec.times >= th.settle)
    obs = [observed[k] for k in settled]
    if not obs and rec.jammed_at is not None and observed and observed[-1] == JAM:
        obs = [o for o in observed if o == JAM]
    return obs


def judge_run(rec: Recording, th: Thresholds, predicted: Sequence[ObservedMode],
              jam_force: float | None = None,
              required: float = MODE_FRACTION_REQUIRED) -> tuple[Verdict, list[ObservedMode]]:
    """Classify ``rec`` and judge it against the ``predicted`` modes (``[JAM]`` for a predicted
    jam): a fault verdict when the run faulted, else :func:`sim.compare.compare_modes` on the
    judged steps. Returns ``(verdict, observed mode per recorded step)``."""
    observed = observed_modes(rec, th, jam_force=jam_force)
    if rec.fault is not None:
        return fault_verdict(rec.fault), observed
    return compare_modes(judged_steps(rec, observed, th), predicted, required), observed
