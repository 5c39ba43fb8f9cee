"""Seeded random systems for benchmarks and scale tests.

A random system is a random convex polygonal workpiece with ``n_c`` contacts on its boundary
(inward unit normals, Sec. 3 / Fig. 1), and a manipulator with a random contact Jacobian
``J (2 n_c, n_theta)`` (eq. 5): ``|tau_I| = n_c - 3`` effort-controlled joints plus
``n_velocity`` velocity-controlled ones, so ``3 + |tau_I| = n_c`` and the number of candidate
modes is eq. (49) with ``dof = n_c`` (73,789 at ``n_c = 12``, the paper's Sec. 4.7 count).

Everything is a pure function of the seed (``numpy.random.default_rng(seed)``), so the same
seed gives the same system in every process and on every machine running the same NumPy.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from planner.errors import InputError
from planner.model.system import System

#: Largest supported number of contacts (eq. 49 grows like 3^n_c; see docs/scaling.md).
MAX_CONTACTS = 40


def random_convex_polygon(rng: np.random.Generator, n_vertices: int = 8) -> np.ndarray:
    """Vertices ``(n_vertices, 2) [m]`` of a random convex polygon, counter-clockwise.

    Points on a random ellipse (semi-axes 0.5..2 m) at sorted random angles, with a random
    offset of the centre; points on an ellipse in angular order form a convex polygon.
    """
    a, b = rng.uniform(0.5, 2.0, size=2)
    ang = np.sort(rng.uniform(0.0, 2 * np.pi, n_vertices))
    # Keep the vertices apart so no edge is degenerate.
    ang = ang + np.linspace(0.0, 0.05, n_vertices)
    centre = rng.normal(0.0, 0.2, 2)
    return np.c_[a * np.cos(ang), b * np.sin(ang)] + centre


def contacts_on_polygon(
    rng: np.random.Generator, vertices: np.ndarray, n_contacts: int
) -> tuple[np.ndarray, np.ndarray]:
    """Random contact points ``(n_c, 2) [m]`` on the edges and inward normals ``(n_c, 2)``.

    Edges are chosen with probability proportional to their length; the inward normal of a
    counter-clockwise edge ``e`` is ``rot90(e) / |e|`` (points into the workpiece, conventions).
    """
    nxt = np.roll(vertices, -1, axis=0)
    edges = nxt - vertices
    length = np.linalg.norm(edges, axis=1)
    pick = rng.choice(len(vertices), size=n_contacts, p=length / length.sum())
    s = rng.uniform(0.05, 0.95, n_contacts)
    points = vertices[pick] + s[:, None] * edges[pick]
    e = edges[pick] / length[pick, None]
    normals = np.c_[-e[:, 1], e[:, 0]]
    return points, normals


def random_system(
    seed: int,
    n_contacts: int,
    *,
    n_velocity: int = 2,
    n_effort: int | None = None,
    mu_range: tuple[float, float] = (0.0, 0.8),
    loads: str = "planted",
) -> System:
    """A seeded random system with a random manipulator Jacobian.

    Parameters
    ----------
    seed : int
        Seed of ``numpy.random.default_rng``.
    n_contacts : int
        Number of contacts ``n_c >= 3``.
    n_velocity : int
        Velocity-controlled joints (commanded speeds ~ N(0, 1) [rad/s]); at least 1 so the
        system moves.
    n_effort : int, optional
        Effort-controlled joints ``|tau_I|``; default ``n_c - 3``, giving
        ``3 + |tau_I| = n_c`` kinematic constraints per candidate mode (eq. 29).
    mu_range : (lo, hi)
        Friction coefficients are uniform in this range.
    loads : "planted" or "random"
        ``"random"``: external wrench, joint loads and efforts all random -- such systems are
        usually force-infeasible (jammed) already at the root of :mod:`planner.predict.search`.
        ``"planted"`` (default): a random contact force ``c`` inside the friction cones (about
        a third of the contacts carry none) is drawn and ``g_obj = -W c`` and
        ``tau_E = J_E^T c + g_man_E`` are set so that the equilibrium of eq. (26) is solvable;
        the benchmark systems are then not trivially jammed.

    Returns
    -------
    System
        Contacts on a random convex workpiece, ``J (2 n_c, n_effort + n_velocity)`` with entries
        ~ N(0, 1), joint order shuffled, external wrench ~ N(0, 1) [N, N, N m], joint
        loads ~ N(0, 0.3), efforts ~ N(0, 2) [N m].
    """
    if isinstance(n_contacts, bool) or not isinstance(n_contacts, (int, np.integer)):
        raise InputError(f"n_contacts: expected an integer, got {type(n_contacts).__name__}")
    if not 3 <= n_contacts <= MAX_CONTACTS:
        raise InputError(f"n_contacts: expected 3..{MAX_CONTACTS}, got {n_contacts}")
    if n_velocity < 1:
        raise InputError(f"n_velocity: expected >= 1 velocity-controlled joint, got {n_velocity}")
    n_e = n_contacts - 3 if n_effort is None else n_effort
    if n_e < 0:
        raise InputError(f"n_effort: expected >= 0, got {n_e}")
    lo, hi = mu_range
    if not (0.0 <= lo <= hi):
        raise InputError(f"mu_range: expected 0 <= lo <= hi, got ({lo}, {hi})")
    rng = np.random.default_rng(seed)
    vertices = random_convex_polygon(rng, n_vertices=int(rng.integers(4, 10)))
    points, normals = contacts_on_polygon(rng, vertices, n_contacts)
    mu = rng.uniform(lo, hi, n_contacts)
    g_obj = rng.normal(0.0, 1.0, 3)
    n_t = n_e + n_velocity
    J = rng.normal(0.0, 1.0, (n_contacts, 2, n_t))
    order = rng.permutation(n_t)
    joints: list[dict[str, float]] = []
    for j in order:
        if j < n_e:
            joints.append({"effort": float(rng.normal(0.0, 2.0))})
        else:
            joints.append({"velocity": float(rng.normal(0.0, 1.0))})
    g_man = rng.normal(0.0, 0.3, n_t)
    if loads not in ("planted", "random"):
        raise InputError(f"loads: expected 'planted' or 'random', got {loads!r}")
    system = System.from_contacts(
        points=points,
        normals=normals,
        mu=mu,
        external_wrench=g_obj,
        jacobian=J[:, :, order],
        joints=joints,
        joint_loads=g_man,
    )
    if loads == "random":
        return system
    c_n = rng.uniform(0.0, 1.0, n_contacts) * (rng.random(n_contacts) > 1 / 3)
    c_t = rng.uniform(-1.0, 1.0, n_contacts) * mu * c_n
    c = np.c_[c_n, c_t].reshape(-1)
    E = system.effort_joints
    inputs = np.array(system.joint_inputs)
    inputs[E] = system.J[:, E].T @ c + g_man[E]
    return System.from_contacts(
        points=points,
        normals=normals,
        mu=mu,
        external_wrench=-(system.W @ c),
        jacobian=J[:, :, order],
        joints=[{"effort" if j in set(E.tolist()) else "velocity": float(inputs[j])}
                for j in range(n_t)],
        joint_loads=g_man,
    )


def random_multibody_system(
    seed: int,
    n_bodies: int,
    n_contacts: int,
    *,
    n_velocity: int = 2,
    n_effort: int = 0,
    body_contact_share: float = 0.4,
    mu_range: tuple[float, float] = (0.0, 0.8),
) -> System:
    """A seeded random system of ``n_b`` workpieces (:mod:`planner.model.bodies`), loads planted.

    Each workpiece is a random convex polygon placed side by side (``1.5 m`` apart); each
    contact lies on the boundary of a random body ``a_i`` (normal into it) and touches, with
    probability ``body_contact_share`` (when ``n_b > 1``), another random body ``b_i`` (zero
    Jacobian rows, eq. 5), else the manipulator (random Jacobian rows ~ N(0, 1)). Every body
    has at least one contact. Loads are planted as in :func:`random_system`: a contact force
    ``c`` strictly inside the friction cones (``c_n`` in 0.1..1 N) gives ``g_obj = -W c``
    (3 n_b,) and ``tau_E = J_E^T c + g_man_E``, so eq. (26) is solvable.

    Returns
    -------
    System
        ``W (3 n_b, 2 n_c)``, ``J (2 n_c, n_effort + n_velocity)``, joint order shuffled.
    """
    for name, value, lo in (("n_bodies", n_bodies, 1), ("n_contacts", n_contacts, n_bodies),
                            ("n_velocity", n_velocity, 1), ("n_effort", n_effort, 0)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
            raise InputError(f"{name}: expected an integer >= {lo}, got {value!r}")
    if n_contacts > MAX_CONTACTS:
        raise InputError(f"n_contacts: expected at most {MAX_CONTACTS}, got {n_contacts}")
    lo_mu, hi_mu = mu_range
    if not (0.0 <= lo_mu <= hi_mu):
        raise InputError(f"mu_range: expected 0 <= lo <= hi, got ({lo_mu}, {hi_mu})")
    rng = np.random.default_rng(seed)
    polys = [random_convex_polygon(rng, n_vertices=int(rng.integers(4, 8))) + (1.5 * a, 0.0)
             for a in range(n_bodies)]
    owner = np.concatenate([np.arange(n_bodies),
                            rng.integers(0, n_bodies, n_contacts - n_bodies)])
    rng.shuffle(owner)
    points, normals, bodies = np.empty((n_contacts, 2)), np.empty((n_contacts, 2)), []
    for i, a in enumerate(owner):
        p, n = contacts_on_polygon(rng, polys[a], 1)
        points[i], normals[i] = p[0], n[0]
        other = -1
        if n_bodies > 1 and rng.random() < body_contact_share:
            other = int(rng.choice([b for b in range(n_bodies) if b != a]))
        bodies.append((int(a), other))
    n_t = n_effort + n_velocity
    J = rng.normal(0.0, 1.0, (n_contacts, 2, n_t))
    J[[i for i, (_, b) in enumerate(bodies) if b >= 0]] = 0.0
    mu = rng.uniform(lo_mu, hi_mu, n_contacts)
    g_man = rng.normal(0.0, 0.3, n_t)
    is_effort = rng.permutation(n_t) < n_effort
    inputs = rng.normal(0.0, 1.0, n_t)
    c_n = rng.uniform(0.1, 1.0, n_contacts)  # every contact loaded: no mode sits on c_n = 0
    c = np.c_[c_n, rng.uniform(-1.0, 1.0, n_contacts) * mu * c_n].reshape(-1)
    Jm = J.reshape(2 * n_contacts, n_t)
    inputs[is_effort] = Jm[:, is_effort].T @ c + g_man[is_effort]
    system = System.from_contacts(
        points=points, normals=normals, mu=mu, bodies=bodies, n_bodies=n_bodies,
        jacobian=J, joints=[{"effort" if e else "velocity": float(v)}
                            for e, v in zip(is_effort, inputs)],
        joint_loads=g_man,
    )
    return dataclasses.replace(system, g_obj=-(system.W @ c))
