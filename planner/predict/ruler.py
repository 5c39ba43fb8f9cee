"""The ruler on two approaching fingers (Trinkle & Zeng 1994, Section 5.1): its switch positions,
predicted by the planner and in closed form.

A rod of weight ``W`` rests on two fingertips below it that move toward each other. With one
Coulomb coefficient the finger farther from the centre of mass slides until both are
equidistant; with static ``mu_s`` and kinetic ``mu_k`` sliding alternates.

:func:`predicted_switches` finds the switches with the planner: for each stage it builds the
two-contact system (:func:`ruler_system`, eqs. 1-5) with the sliding contact at ``mu_k`` and the
rolling one at ``mu_s`` and bisects the sliding finger's distance to the centre of mass for
the point where the stage's mode (``R S``) stops being feasible
(:func:`planner.predict.feasibility.feasible_modes`). :func:`theory_switches` is the closed
form, an independent check. Its derivation (quasistatic; rod weight ``W`` at the centre of
mass; fingers below the rod at distances ``l_1``, ``l_2`` from it, moving toward each other at
equal speed):

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

import numpy as np

from planner.errors import InputError
from planner.model.system import System
from planner.predict.feasibility import feasible_modes

#: Rod thickness over its length (the shipped ruler scenes).
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
