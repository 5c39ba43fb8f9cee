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

import numpy as np

from planner.model.system import System
from planner.predict.feasibility import feasible_modes
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


def observed_switches(rec: Recording, tokens: np.ndarray, body_names: tuple[str, ...]
                      ) -> tuple[list[float], list[int]]:
    """Switch positions from a recording and its (window-averaged) tokens: when the sliding
    finger changes from ``i`` to ``j``, the distance of finger ``i`` to the rod's COM [m].

    The hand-over is dated at the middle of the stretch where neither or both fingers read
    sliding (the window mean of the stopping finger's slip falls below the threshold as late as
    the starting finger's rises above it early, so the middle is unbiased). A run that ends
    without another single slider records the switch where the last slider stopped."""
    iw = body_names.index("workpiece")
    ifs = [body_names.index("finger1"), body_names.index("finger2")]
    T = len(rec.times)
    slider = np.full(T, -1)
    for k in range(T):
        s = [j for j in (0, 1) if tokens[k, j] in ("S+", "S-")]
        if len(s) == 1:
            slider[k] = s[0]
    positions: list[float] = []
    sliders: list[int] = []

    def record(finger: int, k: int) -> None:
        xc = rec.poses[k, iw, 0]
        positions.append(float(abs(rec.poses[k, ifs[finger], 0] - xc)))
        sliders.append(finger)

    prev, end = -1, -1  # current single slider, the last step it was alone
    for k in range(T):
        cur = int(slider[k])
        if cur < 0:
            continue
        if prev >= 0 and cur != prev:
            record(prev, (end + k + 1) // 2)
        prev, end = cur, k
    if prev >= 0 and end < T - 1:
        record(prev, end + 1)
    return positions, sliders
