"""The ruler on two approaching fingers (Trinkle & Zeng 1994, Section 5.1).

A rod of length ``length`` [m] and weight ``weight`` [N] rests on two fingertips below it that move
toward each other at ``speed`` [m/s] each. With one Coulomb coefficient the finger farther from
the centre of mass slides until both are equidistant; with static ``mu_s`` and kinetic ``mu_k``
sliding alternates and the sliding finger stops when ``mu_k l_r = mu_s l_s`` (switch ratio
``mu_k / mu_s``).

The *predicted* switch positions come from the planner: for each stage :func:`predicted_switches`
builds the two-contact system (eqs. 1-5) with the sliding contact at ``mu_k`` and the rolling one
at ``mu_s`` and bisects the sliding finger's distance to the COM for the point where the stage's
mode (``R S``) stops being feasible (:func:`planner.predict.feasibility.feasible_modes`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from planner.model.system import System
from planner.predict.feasibility import feasible_modes
from sim.compare import Outcome, Verdict
from sim.run import Recording
from sim.scene import (
    Body,
    BodyKind,
    Circle,
    ContactPair,
    Load,
    Polygon,
    Scene,
    preload_depth,
)

THICKNESS_RATIO = 0.05


def ruler_system(x: tuple[float, float], weight: float, thickness: float, mu: np.ndarray,
                 speed: float = 1.0) -> System:
    """Planner system of the rod with fingers at COM-relative abscissae ``x`` [m] (left, right),
    left finger moving +x, right finger -x at ``speed``. Origin = COM (eq. 2)."""
    pts = np.array([[x[0], -thickness / 2], [x[1], -thickness / 2]])
    nrm = np.array([[0.0, 1.0], [0.0, 1.0]])
    # t = rot90(n) = (-1, 0): the left finger's +x velocity is v_t = -speed
    vel = np.array([[0.0, -speed], [0.0, speed]])
    return System.from_contacts(points=pts, normals=nrm, mu=mu,
                                external_wrench=(0.0, -weight, 0.0), contact_velocities=vel)


def _stage_mode(sliding: int) -> str:
    return "R1 S-2" if sliding == 1 else "S+1 R2"


def predicted_switches(d_left: float, d_right: float, weight: float, thickness: float,
                       mu_s: float, mu_k: float, n_max: int = 8, min_distance: float = 0.0
                       ) -> tuple[list[float], list[int]]:
    """Switch positions [m] (sliding finger's distance to the COM) and which finger (0 left,
    1 right) slid before each switch, from the planner's mode predictions."""
    dist = [float(d_left), float(d_right)]
    # the first slider: the one whose sliding mode is feasible with mu_s at the other contact
    sys0 = ruler_system((-dist[0], dist[1]), weight, thickness, np.array([mu_s, mu_s]))
    labels = feasible_modes(sys0).labels
    sliding = 0 if "S+1 R2" in labels else 1
    positions: list[float] = []
    sliders: list[int] = []
    for _ in range(n_max):
        r = 1 - sliding
        mu = np.array([mu_k, mu_s]) if sliding == 0 else np.array([mu_s, mu_k])

        def feasible(ls: float, s: int = sliding, rr: int = r, m: np.ndarray = mu) -> bool:
            d = [0.0, 0.0]
            d[s], d[rr] = ls, dist[rr]
            p = feasible_modes(ruler_system((-d[0], d[1]), weight, thickness, m))
            return _stage_mode(s) in p.labels

        lo, hi = 0.0, dist[sliding]
        if not feasible(hi):
            break
        if feasible(1e-9 * max(dist)):
            break  # slides all the way to the COM: no further switch
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if feasible(mid):
                hi = mid
            else:
                lo = mid
        pos = 0.5 * (lo + hi)
        if pos < min_distance:
            break
        positions.append(pos)
        sliders.append(sliding)
        dist[sliding] = pos
        if abs(mu_s - mu_k) < 1e-12:
            break  # single mu: after l_s = l_r both stay equidistant (chatter), one switch
        sliding = r
    return positions, sliders


def ruler_scene(*, length: float, weight: float, mass: float, x_left: float, x_right: float,
                speed: float, mu_s: float, mu_k: float | None, finger_radius: float) -> Scene:
    """Rod (COM at the origin) on two driven fingertips at ``x_left < 0 < x_right`` [m]."""
    h = THICKNESS_RATIO * length
    rod = Polygon(((-length / 2, -h / 2), (length / 2, -h / 2), (length / 2, h / 2),
                   (-length / 2, h / 2)))
    work = Body("workpiece", (rod,), mass=mass, com=(0.0, 0.0),
                inertia=mass * (length ** 2 + h ** 2) / 12.0)
    y = -h / 2 - finger_radius + preload_depth(length)
    left = Body("finger1", (Circle((0.0, 0.0), finger_radius),), pose=(x_left, y, 0.0),
                kind=BodyKind.DRIVEN, twist=lambda t, s: (speed, 0.0, 0.0))
    right = Body("finger2", (Circle((0.0, 0.0), finger_radius),), pose=(x_right, y, 0.0),
                 kind=BodyKind.DRIVEN, twist=lambda t, s: (-speed, 0.0, 0.0))
    pairs = (ContactPair("c1", "finger1", "workpiece", mu_static=mu_s, mu_kinetic=mu_k),
             ContactPair("c2", "finger2", "workpiece", mu_static=mu_s, mu_kinetic=mu_k))
    return Scene(bodies=(work, left, right), pairs=pairs,
                 loads=(Load("workpiece", (0.0, -weight), 0.0),),
                 bounds=(-length, -length, length, length), length_scale=length,
                 meta={"thickness": h})


#: A finger carries the motion when its window-mean slip exceeds the slip threshold and this
#: many times the other finger's (a creeping "sticking" finger does not hide which one slides).
DOMINANCE = 2.0


def sliding_finger(rec: Recording, slip_speed: float, window: float) -> np.ndarray:
    """(T,) index of the finger that carries the motion (0 left, 1 right), -1 where neither
    or both do: window-mean ``|v_t|`` (:func:`sim.classify.window_mean`) above ``slip_speed``
    and above :data:`DOMINANCE` times the other finger's."""
    from sim.classify import window_mean

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
    from sim.classify import window_mean

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
