"""Closed-form switch positions of the ruler on two approaching fingers (Sec. 5.1), and the
switches a recording shows -- an independent check of :mod:`sim.scenes.ruler` (which predicts
with the planner).

Derivation (quasistatic; rod weight ``W`` at the centre of mass; fingers below the rod at
distances ``l_1``, ``l_2`` from it, moving toward each other at equal speed):

* moments about the centre of mass and vertical balance give the normal forces
  ``N_1 = W l_2 / (l_1 + l_2)``, ``N_2 = W l_1 / (l_1 + l_2)``: the *far* finger carries less;
* horizontal balance: the two friction forces are equal and opposite, ``|F_1| = |F_2| = F``
  (they act on the same line, so they add no moment). Both start static; the finger whose
  capacity ``mu_s N`` is smaller -- the far one -- slides first, with ``F = mu_k N_s``;
* the other finger sticks while ``F <= mu_s N_r``, i.e. ``mu_k l_r <= mu_s l_s`` (the slider's
  distance ``l_s`` shrinks, the sticking finger's ``l_r`` is fixed on the rod). The slider
  stops when ``mu_k N_s = mu_s N_r``: ``l_s = (mu_k / mu_s) l_r = rho l_r``; at that instant the
  static capacity of the sticking finger is reached and it starts to slide -- roles swap;
* so switch ``k`` happens with the sliding finger at ``rho^k b`` from the centre of mass, ``b``
  the near finger's initial distance, and the sliding finger alternates (far first).

With one coefficient (``rho = 1``) the far finger slides until ``l_1 = l_2`` (one switch); the
fingers then meet under the centre of mass.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from planner.errors import InputError
from sim.run import Recording, RunSettings, run_scene


def theory_switches(d_left: float, d_right: float, mu_s: float, mu_k: float, n: int
                    ) -> tuple[list[float], list[int]]:
    """The first ``n`` switch positions [m] (sliding finger's distance to the centre of mass)
    and which finger (0 left, 1 right) slid before each, for fingers starting ``d_left``,
    ``d_right`` > 0 [m] from the centre of mass (module docstring)."""
    if not (d_left > 0 and d_right > 0 and d_left != d_right):
        raise InputError(f"fingers: expected two different distances > 0, got {d_left}, "
                         f"{d_right}")
    if not 0 < mu_k <= mu_s:
        raise InputError(f"friction: expected 0 < mu_k <= mu_s, got {mu_s}, {mu_k}")
    rho = mu_k / mu_s
    near = min(d_left, d_right)
    far_finger = 0 if d_left > d_right else 1
    count = 1 if rho == 1 else n
    return ([rho ** k * near for k in range(1, count + 1)],
            [far_finger if k % 2 == 0 else 1 - far_finger for k in range(count)])


def sliding_per_step(rec: Recording, slip_speed: float) -> np.ndarray:
    """(T,) index of the one finger sliding (``|v_t| > slip_speed``) while the other does not,
    ``-1`` otherwise (both, neither, or a missing contact)."""
    v = np.where(rec.present, np.abs(rec.slip_velocity), np.inf)
    s = np.full(len(rec.times), -1)
    s[(v[:, 0] > slip_speed) & (v[:, 1] <= slip_speed)] = 0
    s[(v[:, 1] > slip_speed) & (v[:, 0] <= slip_speed)] = 1
    return s


def recorded_switches(rec: Recording, slip_speed: float, hold: float
                      ) -> tuple[list[float], list[int]]:
    """Switches in a recording: runs of one sliding finger lasting at least ``hold`` [s] are
    kept (shorter ones -- hand-over transients -- are ignored); at a change of the kept slider,
    the previous slider's distance to the rod's centre of mass [m] at the end of its run."""
    s = sliding_per_step(rec, slip_speed)
    step = float(rec.times[1] - rec.times[0]) if len(rec.times) > 1 else 1.0
    need = max(1, int(round(hold / step)))
    runs: list[list[int]] = []  # [finger, first step, end step]
    k = 0
    while k < len(s):
        j = k
        while j < len(s) and s[j] == s[k]:
            j += 1
        if s[k] >= 0 and j - k >= need:
            if runs and runs[-1][0] == s[k]:
                runs[-1][2] = j
            else:
                runs.append([int(s[k]), k, j])
        k = j
    iw = rec.body_names.index("workpiece")
    fingers = [rec.body_names.index("finger1"), rec.body_names.index("finger2")]
    positions, sliders = [], []
    for (f0, _, end), _next in zip(runs, runs[1:]):
        positions.append(float(abs(rec.poses[end - 1, fingers[f0], 0]
                                   - rec.poses[end - 1, iw, 0])))
        sliders.append(f0)
    return positions, sliders


#: time step [s] and finger speed [m/s] per engine (rod 0.1 m); errors grow with speed (inertia)
SETTINGS = {"pymunk": (2e-3, 3e-4), "mujoco": (1e-3, 1.5e-4)}
TOLERANCE, SWITCHES = 0.02, 5
#: The run loop switches a contact to kinetic friction when its |v_t| exceeds this fraction of
#: the finger speed. A quasistatic switch is instantaneous; the rod (mass ``m``) needs
#: ``t = sqrt(2 m v_th / Fdot)`` to reach the threshold ``v_th`` once the sticking finger's
#: static capacity is exceeded at the rate ``Fdot = (mu_s + mu_k) dN/dt``, and the slider runs on
#: by ``2 v t``: 7.6 um at the first hand-over of 0.5 / 0.3 from (-0.2, 0.35) at 0.1 v (measured
#: ~10 um per hand-over in MuJoCo), sqrt(5) less at 0.02 v; 0.02 v is still > 150 x the creep of
#: a sticking finger in either engine (< 2e-8 m/s; docs/simulation.md).
SWITCH_OF_SPEED = 0.02
#: A miss is ``inconclusive`` (not ``disagreed``) when the engine measurably cannot hold the
#: hand-overs: the non-sliding finger's mean |v_t| above this fraction of the slip threshold
#: (pymunk measures ~1e-8 m/s, 3e-4 of its threshold), or finger contacts missing on more than
#: this fraction of the recorded steps (a resting contact is never missing in pymunk).
CREEP_OF_SLIP = 0.1
LOST_FRACTION = 0.01


def run_case(engine: str, mu_s: float, mu_k: float, left: float, right: float,
             length: float = 0.1, speed: float | None = None,
             dt: float | None = None) -> dict[str, Any]:
    """One ruler run judged against the closed form; a JSON-ready row."""
    dt0, v = SETTINGS[engine]
    v = v if speed is None else speed
    dt = dt0 if dt is None else dt
    pred, who = theory_switches(-left * length, right * length, mu_s, mu_k, SWITCHES)
    end = pred[-1] + 0.7 * pred[-2]  # stop shortly after the last switch
    duration = ((right - left) * length - end) / (2 * v)
    from sim.backends import make_backend
    from sim.scenes.ruler import ruler_scene

    scene = ruler_scene(length=length, weight=1.0, mass=0.1, x_left=left * length,
                        x_right=right * length, speed=v, mu_s=mu_s, mu_k=mu_k,
                        finger_radius=0.03 * length)
    t0 = time.perf_counter()
    rec = run_scene(scene, make_backend(engine),
                    RunSettings(duration=duration, dt=dt, slip_speed=SWITCH_OF_SPEED * v,
                                penetration_tol=0.01 * length, record_every=5))
    wall = time.perf_counter() - t0
    slip = 0.1 * v
    pos, sl = recorded_switches(rec, slip, hold=0.05)
    s = sliding_per_step(rec, slip)
    stick = [abs(rec.slip_velocity[k, 1 - s[k]]) for k in range(len(s)) if s[k] >= 0]
    creep = float(np.mean(stick)) if stick else float("nan")
    errors = [abs(p - q) / q for p, q in zip(pos, pred)]
    lost = float(np.mean(~rec.present)) if len(rec.times) else 0.0
    cause = None
    if rec.fault is not None:
        status = "fault"
    elif len(pos) >= SWITCHES and sl[:SWITCHES] == who and max(errors[:SWITCHES]) <= TOLERANCE:
        status = "agreed"
    elif creep > CREEP_OF_SLIP * slip or lost > LOST_FRACTION:
        status = "inconclusive"
        cause = (f"the sticking finger creeps at {creep:.2g} m/s (slip threshold {slip:.2g} "
                 f"m/s) and the finger contacts are missing on {lost:.1%} of the steps "
                 "(chatter): the engine cannot hold the static/kinetic hand-overs")
    else:
        status = "disagreed"
    return {"engine": engine, "mu_s": mu_s, "mu_k": mu_k, "left": left, "right": right,
            "speed_m_per_s": v, "dt_s": dt, "status": status, "theory_m": pred,
            "observed_m": pos[:SWITCHES + 1], "sliders_theory": who, "sliders": sl[:SWITCHES + 1],
            "relative_errors": errors[:SWITCHES], "creep_m_per_s": creep,
            "contact_lost_fraction": lost,
            "cause": cause, "wall_s": wall,
            "fault": rec.fault.reason if rec.fault else None}
