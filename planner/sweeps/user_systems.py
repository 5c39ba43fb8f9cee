"""Seeded random system files of the kinds a user writes (the geometry-first form of
docs/file-formats.md, "Geometry first"), each with what a hand derivation says the planner must
predict for it.

Every draw is the JSON content of a system file -- ``gravity``, a ``workpiece`` polygon (or
``workpieces``) with its mass, named ``surfaces`` and ``fingers`` with world-frame velocities,
contacts placed at polygon vertices or at ``edge`` + ``at``, ``friction`` groups -- to be read
with :func:`planner.files.system_file.system_from_dict` exactly as ``qsplan simulate FILE``
reads a file. Kinds (:data:`KINDS`):

``acute``
    a triangle (base corners 20-60 deg) or a rhombus (20-60 deg corners, leaning either way)
    standing on a table on two vertex contacts, pushed on its left side edge by one finger
    (frictionless or rough) moving horizontally or up to 25 deg off it;
``supports``
    a box on 3-12 table contacts along its bottom edge (force-indeterminate), pushed on its
    left face by a frictionless or rough finger; half of them just below the height where
    sliding gives way to tipping (:func:`slide_height`);
``stacked``
    two or three blocks, each resting on the one below with its bottom corners (body-body
    vertex contacts), the lowest on a table; a frictionless or rough finger pushes one of them;
``static``
    nothing driven: a ladder (a rhombus with 20-60 deg corners) between a floor and a wall, or a
    box / trapezoid / triangle on an incline (the incline drawn, or the gravity vector tilted);
    it stays (static equilibria) or moves (none).

Sizes are log-uniform from 2 mm to 3 m, densities 200-3000 kg/m^3 over a thickness of half the
size, finger speeds log-uniform 0.1 mm/s to 0.1 m/s; half of all draws are mirrored about the
world ``y`` axis (:func:`planner.sweeps.user_files.mirror_system`: the prediction is the
mirror image, ``S+`` and ``S-`` swapped). Claims (:class:`planner.sweeps.user_files.Claim`) are
derived in the docstrings below from the equilibrium of the weight, the finger force and the
Coulomb cones (eqs. 8, 26) and made only where the derivation holds with a margin
(:data:`~planner.sweeps.user_files.MARGIN`).

Units: SI (m, kg, N, rad, s).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from planner.sweeps.user_files import (
    MARGIN,
    Claim,
    G,
    UserDraw,
    centroid,
    draw_direction,
    draw_finger,
    draw_mass,
    draw_size,
    draw_speed,
    finish_draw,
    pushed_labels,
)

#: The kinds of drawn systems (module docstring).
KINDS = ("acute", "supports", "stacked", "static")

# ---- acute corners ---------------------------------------------------------------------------
def acute(rng: np.random.Generator) -> UserDraw:
    """A triangle or rhombus with 20-60 deg corners on a table, pushed on its left edge.

    Claim (finger moving horizontally, left edge at ``phi`` <= 90 deg from the table, the
    finger's force direction turned by ``psi`` within its cone ``|psi| <= atan mu_f`` towards the
    horizontal): the force ``P (sin(phi + psi), -cos(phi + psi))`` presses down; sliding both
    table corners (``P_x = mu_t (W + P_y)``) needs ``tan(phi + psi) > mu_t``, and its line of
    action meets the table at ``x_hit = r_x + r_y tan(phi + psi)`` -- inside the base ``b`` no
    moment can lift the rear corner (``N_0 b = P (b cos - ...) + W (b - c_x) > 0``). So: with
    ``x_hit < (1 - MARGIN) b`` at ``phi + atan mu_f``, the sliding mode ``S-1 S-2 R3`` is
    feasible when ``tan(phi + atan mu_f) > (1 + MARGIN) mu_t`` and nothing is (a jam: the
    finger's normal speed ``v sin phi > 0`` must be met by a body that cannot slide or tip) when
    ``tan(phi + atan mu_f) < mu_t / (1 + MARGIN)``."""
    groups: dict[str, tuple[float, float]] = {"table": (0.05, 1.0)}
    friction = {"table": float(rng.uniform(0.05, 1.0))}
    size = draw_size(rng)
    if rng.integers(2):
        shape = "triangle"
        a, b_ang = np.radians(rng.uniform(20.0, 60.0, 2))
        xa = size * math.tan(b_ang) / (math.tan(a) + math.tan(b_ang))
        poly = np.array([[0.0, 0.0], [size, 0.0], [xa, xa * math.tan(a)]])
        phi, left = float(a), 2
        corners = [float(np.degrees(a)), float(np.degrees(b_ang))]
    else:
        shape = "rhombus"
        th = float(np.radians(rng.uniform(20.0, 60.0)))
        lean = 1.0 if rng.integers(2) else -1.0  # leaning right: the left edge is acute
        c, s = size * math.cos(th) * lean, size * math.sin(th)
        poly = np.array([[0.0, 0.0], [size, 0.0], [size + c, s], [c, s]])
        phi, left = (th if lean > 0 else math.pi - th), 3
        corners = [float(np.degrees(th))]
    base = size
    mu_f_name, mu_f = draw_finger(rng, groups, friction)
    frac = float(rng.uniform(0.1, 0.9))  # from the bottom vertex up the left edge
    bottom = poly[0]
    top = poly[left]
    r = bottom + frac * (top - bottom)
    psi = draw_direction(rng)
    v = draw_speed(rng)
    data = {
        "gravity": [0.0, -G],
        "workpiece": {"polygon": poly.tolist(), "mass": draw_mass(poly, size, rng)},
        "friction": friction,
        "surfaces": [{"name": "table", "edge": [[-2.0 * size, 0.0], [3.0 * size, 0.0]]}],
        "fingers": [{"name": "pusher", "velocity": [v * math.cos(psi), v * math.sin(psi)]}],
        "contacts": [{"vertex": 0, "surface": "table", "mu": "table"},
                     {"vertex": 1, "surface": "table", "mu": "table"},
                     {"edge": left, "at": 1.0 - frac, "finger": "pusher", "mu": mu_f_name}],
    }
    claim = Claim()
    turn = phi + math.atan(mu_f)
    if psi == 0.0 and phi <= math.pi / 2 and turn < math.pi / 2:
        x_hit = r[0] + r[1] * math.tan(turn)
        mu_t = friction["table"]
        why = (f"left edge {math.degrees(phi):.1f} deg, finger cone {math.degrees(turn - phi):.1f}"
               f" deg: tan = {math.tan(turn):.3f} vs mu_table {mu_t:.3f}; force line meets the "
               f"table at {x_hit / base:.2f} of the base")
        if x_hit < (1 - MARGIN) * base:
            if math.tan(turn) > (1 + MARGIN) * mu_t:
                claim = Claim(contains=("S-1 S-2 R3",), why=why)
            elif math.tan(turn) < mu_t / (1 + MARGIN):
                claim = Claim(empty=True, why=why)
    params = {"shape": shape, "corners_deg": corners, "size_m": size,
              "left_edge_deg": float(np.degrees(phi)), "push_at": frac,
              "direction_deg": float(np.degrees(psi)), "mu_finger": mu_f}
    return finish_draw("acute", data, claim, rng, params, groups)


# ---- force-indeterminate supports ------------------------------------------------------------
def slide_height(width: float, mu_table: float, mu_finger: float) -> float:
    """Height [m] of a horizontal push on a box's side face below which it can slide on the
    table: ``w (1 + mu_f mu_t) / (2 mu_t)`` (``w / (2 mu_t)`` for a frictionless finger).

    Derivation (moments about the front corner, the box sliding at ``P = mu_t (W - f)`` with the
    finger's tangential force ``f`` (up positive) sticking, ``|f| <= mu_f P``): the supports need
    ``sum (w - x_i) N_i = W w / 2 - w f - h P >= 0``; the most favourable ``f = -mu_f P`` (the
    finger pressing down) gives ``f = -mu_f mu_t W / (1 - mu_f mu_t)`` and ``h <= w (1 + mu_f
    mu_t) / (2 mu_t)``. Infinite when ``mu_f mu_t >= 1`` (the finger can hold the box down)."""
    if mu_finger * mu_table >= 1.0:
        return math.inf
    return width * (1.0 + mu_finger * mu_table) / (2.0 * mu_table)


def supports(rng: np.random.Generator) -> UserDraw:
    """A box on ``k`` (3-12) table contacts along its bottom edge, pushed on its left face.

    Claim (horizontal push at height ``h``): the sliding mode (every support ``S-``, the finger
    ``R``) is feasible when ``h < (1 - MARGIN) h*`` and not when ``h > (1 + MARGIN) h*``,
    ``h* =`` :func:`slide_height`. Half the draws push at 0.75-0.97 of ``h*`` (when that is on
    the face): just below the slide/tip height, where the rear supports carry almost nothing."""
    groups: dict[str, tuple[float, float]] = {"table": (0.1, 1.0)}
    friction = {"table": float(rng.uniform(0.1, 1.0))}
    w = draw_size(rng)
    h = w * float(np.exp(rng.uniform(math.log(0.3), math.log(3.0))))
    poly = np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])
    k = int(rng.integers(3, 13))
    mu_f_name, mu_f = draw_finger(rng, groups, friction)
    h_star = slide_height(w, friction["table"], mu_f)
    just_below = bool(rng.integers(2)) and 0.97 * h_star < 0.95 * h
    hp = float(rng.uniform(0.75, 0.97) * h_star if just_below else rng.uniform(0.05, 0.95) * h)
    psi = 0.0 if just_below else draw_direction(rng)
    inner = np.sort(rng.uniform(0.05, 0.95, k - 2)) if rng.integers(2) else \
        np.linspace(0.0, 1.0, k)[1:-1]
    contacts: list[dict[str, Any]] = [{"vertex": 0, "surface": "table", "mu": "table"}]
    contacts += [{"edge": 0, "at": float(a), "surface": "table", "mu": "table"} for a in inner]
    contacts += [{"vertex": 1, "surface": "table", "mu": "table"},
                 {"edge": 3, "at": 1.0 - hp / h, "finger": "pusher", "mu": mu_f_name}]
    v = draw_speed(rng)
    data = {
        "gravity": [0.0, -G],
        "workpiece": {"polygon": poly.tolist(), "mass": draw_mass(poly, w, rng)},
        "friction": friction,
        "surfaces": [{"name": "table", "edge": [[-2.0 * w, 0.0], [3.0 * w, 0.0]]}],
        "fingers": [{"name": "pusher", "velocity": [v * math.cos(psi), v * math.sin(psi)]}],
        "contacts": contacts,
    }
    claim = Claim()
    slide = pushed_labels(k)
    why = f"push at {hp:.4g} m, slide/tip height {h_star:.4g} m"
    if psi == 0.0 and hp < (1 - MARGIN) * h_star:
        claim = Claim(contains=(slide,), why=why)
    elif psi == 0.0 and hp > (1 + MARGIN) * h_star:
        claim = Claim(excludes=(slide,), why=why)
    params = {"width_m": w, "height_m": h, "supports": k, "push_height_m": hp,
              "slide_height_m": h_star, "just_below": just_below, "mu_finger": mu_f,
              "direction_deg": float(np.degrees(psi))}
    return finish_draw("supports", data, claim, rng, params, groups)


# ---- stacked blocks --------------------------------------------------------------------------
def stacked(rng: np.random.Generator) -> UserDraw:
    """Two or three blocks, each on the one below with its bottom corners, pushed on one block.

    Claim (frictionless finger moving horizontally on block ``p``): the blocks above ``p`` ride
    along (no friction is needed to carry them); of the supports of blocks ``0..p`` (``j = 0``
    the table, ``j`` the corners of block ``j`` on block ``j - 1``) the one that slips has the
    least capacity ``C_j = mu_j sum_{m >= j} W_m`` (the blocks ``j*..p`` move together, every
    support between them holds ``C_j* <= C_j``); so the mode with support ``j*`` sliding
    (``S-``, both corners), every other contact rolling, is feasible when the least capacity is
    below the next by ``MARGIN`` and no sub-stack tips: about the front corner ``x_j`` of each
    support ``j <= p``, ``C_j* (y_f - y_j) <= 0.7 sum_{m >= j} W_m (x_j - x_m)`` (the rear
    corner's normal force ``>= 0`` with a margin)."""
    nb = 2 if rng.integers(2) else 3
    size = draw_size(rng)
    polys, x0, y0, w = [], 0.0, 0.0, size
    for j in range(nb):
        if j:
            w_new = w * float(rng.uniform(0.4, 0.9))
            x0 += float(rng.uniform(0.0, 1.0)) * (w - w_new)
            w = w_new
        h = w * float(rng.uniform(0.3, 1.5))
        polys.append(np.array([[x0, y0], [x0 + w, y0], [x0 + w, y0 + h], [x0, y0 + h]]))
        y0 += h
    groups: dict[str, tuple[float, float]] = {"table": (0.05, 1.0)}
    friction = {"table": float(rng.uniform(0.05, 1.0))}
    shared = bool(rng.integers(2))
    names = ["table"] + (["interface"] * (nb - 1) if shared else
                         [f"interface{j}" for j in range(1, nb)])
    for g in names[1:]:
        groups[g] = (0.05, 1.0)
        friction.setdefault(g, float(rng.uniform(0.05, 1.0)))
    contacts: list[dict[str, Any]] = [{"vertex": 0, "surface": "table", "mu": "table"},
                                      {"vertex": 1, "surface": "table", "mu": "table"}]
    for j in range(1, nb):
        contacts += [{"body": j, "vertex": v, "other": j - 1, "mu": names[j]} for v in (0, 1)]
    p = int(rng.integers(nb))
    mu_f_name, mu_f = draw_finger(rng, groups, friction)
    frac = float(rng.uniform(0.05, 0.95))
    psi = draw_direction(rng)
    contacts.append({"body": p, "edge": 3, "at": 1.0 - frac, "finger": "pusher",
                     "mu": mu_f_name})
    masses = [draw_mass(q, size, rng) for q in polys]
    v = draw_speed(rng)
    span = float(polys[0][1, 0] - polys[0][0, 0])
    data = {
        "gravity": [0.0, -G],
        "workpieces": [{"name": f"block {j}", "polygon": q.tolist(), "mass": m}
                       for j, (q, m) in enumerate(zip(polys, masses))],
        "friction": friction,
        "surfaces": [{"name": "table", "edge": [[-2.0 * span, 0.0], [3.0 * span, 0.0]]}],
        "fingers": [{"name": "pusher", "velocity": [v * math.cos(psi), v * math.sin(psi)]}],
        "contacts": contacts,
    }
    claim = Claim()
    if mu_f == 0.0 and psi == 0.0:
        weight = np.array(masses) * G
        cap = [friction[names[j]] * float(weight[j:].sum()) for j in range(p + 1)]
        order = np.argsort(cap)
        js = int(order[0])
        y_f = float(polys[p][0, 1] + frac * (polys[p][3, 1] - polys[p][0, 1]))
        tips = any(cap[js] * (y_f - polys[j][0, 1]) > 0.7 * sum(
            weight[m] * (polys[j][1, 0] - centroid(polys[m])[0]) for m in range(j, nb))
            for j in range(p + 1))
        unique = len(cap) == 1 or cap[int(order[1])] > (1 + MARGIN) * cap[js]
        if unique and not tips:
            tokens = ["R"] * (2 * nb) + ["R"]
            tokens[2 * js] = tokens[2 * js + 1] = "S-"
            label = " ".join(f"{t}{i + 1}" for i, t in enumerate(tokens))
            claim = Claim(contains=(label,), why=f"capacities {np.round(cap, 6).tolist()} N "
                          f"(support {js} slips), pushed block {p}")
    params = {"blocks": nb, "size_m": size, "pushed": p, "push_at": frac, "mu_finger": mu_f,
              "shared_interface": shared, "direction_deg": float(np.degrees(psi))}
    return finish_draw("stacked", data, claim, rng, params, groups)


# ---- static systems --------------------------------------------------------------------------
def ladder_stands(beta: float, mu_floor: float, mu_wall: float) -> float:
    """The ratio ``2 mu_f (tan beta + mu_w) / (1 + mu_f mu_w)``: a ladder at ``beta`` [rad] from
    the floor, its weight at its middle, stands when it is >= 1 (both contacts at the cone:
    ``N_w = mu_f N_f``, ``N_f = W / (1 + mu_f mu_w)``, moments about the foot ``W cos / 2 =
    N_w sin + mu_w N_w cos``); ``tan beta >= (1 - mu_f mu_w) / (2 mu_f)``."""
    return 2.0 * mu_floor * (math.tan(beta) + mu_wall) / (1.0 + mu_floor * mu_wall)


def static(rng: np.random.Generator) -> UserDraw:
    """A ladder against a wall or a body on an incline; nothing is driven (module docstring).

    Claims: the ladder (:func:`ladder_stands`) and, on an incline at ``alpha``, a body stays
    (``R1 R2``) when ``tan alpha < mu / (1 + MARGIN)`` and its weight's line meets the incline
    inside its base by ``MARGIN`` of the base, and moves (nothing predicted) when ``tan alpha >
    (1 + MARGIN) mu`` or that line misses the base by ``MARGIN`` of it (it tips)."""
    size = draw_size(rng)
    groups: dict[str, tuple[float, float]] = {}
    friction: dict[str, float] = {}
    if rng.integers(2):
        gamma = float(np.radians(rng.uniform(20.0, 60.0)))
        beta = float(np.radians(rng.uniform(np.degrees(gamma) / 2 + 5.0,
                                            90.0 - np.degrees(gamma) / 2 - 5.0)))
        foot, top = np.array([size * math.cos(beta), 0.0]), np.array([0.0, size * math.sin(beta)])
        mid, e = 0.5 * (foot + top), 0.5 * size * math.tan(gamma / 2)
        side = np.array([math.sin(beta), math.cos(beta)])
        poly = np.array([foot, mid + e * side, top, mid - e * side])
        groups["floor"] = (0.05, 1.0)
        friction["floor"] = float(rng.uniform(0.05, 1.0))
        wall: Any = 0.0
        if rng.integers(2):
            groups["wall"] = (0.05, 1.0)
            friction["wall"] = wall = float(rng.uniform(0.05, 1.0))
        data: dict[str, Any] = {
            "gravity": [0.0, -G],
            "workpiece": {"polygon": poly.tolist(), "mass": draw_mass(poly, size, rng)},
            "friction": friction,
            "surfaces": [{"name": "floor", "edge": [[-0.5 * size, 0.0], [2.0 * size, 0.0]]},
                         {"name": "wall", "edge": [[0.0, 0.0], [0.0, 2.0 * size]]}],
            "contacts": [{"vertex": 0, "surface": "floor", "mu": "floor"},
                         {"vertex": 2, "surface": "wall", "mu": "wall" if wall else 0.0}],
        }
        ratio = ladder_stands(beta, friction["floor"], float(wall))
        why = f"ladder at {math.degrees(beta):.1f} deg: stands when {ratio:.3f} >= 1"
        claim = (Claim(contains=("R1 R2",), empty=False, why=why) if ratio > 1 + MARGIN else
                 Claim(empty=True, why=why) if ratio < 1 - MARGIN else Claim(why=why))
        params = {"shape": "ladder", "corner_deg": float(np.degrees(gamma)),
                  "angle_deg": float(np.degrees(beta)), "size_m": size, "wall_mu": wall}
        return finish_draw("static", data, claim, rng, params, groups)
    alpha = float(np.radians(rng.uniform(2.0, 45.0)))
    shape = ("box", "trapezoid", "triangle")[int(rng.integers(3))]
    w = size
    if shape == "triangle":
        a, b = np.radians(rng.uniform(20.0, 60.0, 2))
        xa = w * math.tan(b) / (math.tan(a) + math.tan(b))
        poly = np.array([[0.0, 0.0], [w, 0.0], [xa, xa * math.tan(a)]])
    else:
        h = w * float(rng.uniform(0.3, 2.5))
        sl, sr = (rng.uniform(0.0, 0.3, 2) * w) if shape == "trapezoid" else (0.0, 0.0)
        poly = np.array([[0.0, 0.0], [w, 0.0], [w - sr, h], [sl, h]])
    c = centroid(poly)
    x_hit = float(c[0] - c[1] * math.tan(alpha))  # the weight's line on the incline (downhill -x)
    groups["incline"] = (0.05, 1.0)
    friction["incline"] = mu = float(rng.uniform(0.05, 1.0))
    tilted = bool(rng.integers(2))
    if tilted:  # the incline level, gravity tilted
        gravity = [-G * math.sin(alpha), -G * math.cos(alpha)]
        edge = [[-2.0 * w, 0.0], [3.0 * w, 0.0]]
        placed = poly
    else:
        rot = np.array([[math.cos(alpha), -math.sin(alpha)], [math.sin(alpha), math.cos(alpha)]])
        gravity = [0.0, -G]
        placed = poly @ rot.T
        edge = (np.array([[-2.0 * w, 0.0], [3.0 * w, 0.0]]) @ rot.T).tolist()
    data = {
        "gravity": gravity,
        "workpiece": {"polygon": placed.tolist(), "mass": draw_mass(poly, size, rng)},
        "friction": friction,
        "surfaces": [{"name": "incline", "edge": edge}],
        "contacts": [{"vertex": 0, "surface": "incline", "mu": "incline"},
                     {"vertex": 1, "surface": "incline", "mu": "incline"}],
    }
    t = math.tan(alpha)
    why = (f"incline {math.degrees(alpha):.1f} deg: tan {t:.3f} vs mu {mu:.3f}; weight line at "
           f"{x_hit / w:.2f} of the base")
    if t > (1 + MARGIN) * mu or x_hit < -MARGIN * w:
        claim = Claim(empty=True, why=why)
    elif t < mu / (1 + MARGIN) and x_hit > MARGIN * w:
        claim = Claim(contains=("R1 R2",), empty=False, why=why)
    else:
        claim = Claim(why=why)
    params = {"shape": shape, "incline_deg": float(np.degrees(alpha)), "size_m": size,
              "gravity_tilted": tilted}
    return finish_draw("static", data, claim, rng, params, groups)


DRAWS = {"acute": acute, "supports": supports, "stacked": stacked, "static": static}


def draw_user_system(kind: str, rng: np.random.Generator) -> UserDraw:
    """One draw of ``kind`` (one of :data:`KINDS`)."""
    from planner.errors import InputError

    if kind not in DRAWS:
        raise InputError(f"kind: expected one of {', '.join(KINDS)}, got {kind!r}")
    return DRAWS[kind](rng)
