"""How fast pymunk's solver converges on a scene's joints: the rate of its sweeps, from the
chain's masses and geometry (docs/simulation.md, "pymunk").

Chipmunk2D solves every step's constraints by sweeping them one after the other, each solved
exactly for its own impulse with the others held (sequential impulses: block Gauss-Seidel on
the constraints' effective-mass matrix). For the bilateral constraints of the joints that is
the linear iteration ``x <- -(D + L)^{-1} (U x - b)`` on ``A = J M^{-1} J^T``, ``D`` the
blocks of each constraint's own rows (a pivot's two rows are solved together), ``L`` / ``U``
the couplings to the constraints swept before / after it; a sweep leaves the fraction ``rho``
of the error, the spectral radius of ``G = -(D + L)^{-1} U`` (:func:`gauss_seidel_rate`). Two
constraints acting on one light body at different lever arms are nearly parallel in the metric
``M^{-1}``: a gantry's first link held to a carriage by a gear (``1 / I_1``) and carrying the
second link's gear gives ``rho = I_2 / (I_1 + I_2)``, rising toward 1 with the lever of the
second link's groove point on the first. A body slid by a velocity-controlled joint on the base
has no free coordinate, and the backend makes it kinematic (``kinematic_slides``): its rows
leave the solve. The rows are the ones :class:`sim.backends.pymunk_engine.PymunkBackend` builds
(:func:`joint_rows`); contacts are not included (their rows are unilateral, and Chipmunk sweeps
them first).
"""

from __future__ import annotations

import math

import numpy as np

from sim.scene import Body, BodyKind, Control, JointKind, Scene

Row = dict[str, np.ndarray]  # body name -> (3,) Jacobian (v_x, v_y, omega) of one row


def _point_row(body: Body, point: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """(3,) Jacobian of the velocity of ``point`` [m, world] of ``body`` along
    ``direction`` (unit, world) with respect to the body's twist about its centre of mass."""
    c, s = math.cos(body.pose[2]), math.sin(body.pose[2])
    com = np.array(body.pose[:2]) + np.array([[c, -s], [s, c]]) @ np.asarray(body.com)
    r = point - com
    return np.array([direction[0], direction[1], r[0] * direction[1] - r[1] * direction[0]])


def slid_bodies(scene: Scene) -> set[str]:
    """Bodies of ``scene`` slid by a velocity-controlled prismatic joint on the base: no free
    coordinate, kinematic in pymunk."""
    return {j.body for j in scene.joints if j.parent is None
            and j.kind == JointKind.PRISMATIC and j.control == Control.VELOCITY}


def joint_rows(scene: Scene, kinematic_slides: bool = True) -> list[list[Row]]:
    """Every joint constraint of ``scene`` as pymunk builds it, one list of rows per
    constraint (a pivot: two rows; a groove: the row across it; a gear or a motor: the
    relative angle; a velocity-controlled slide: the row along it), each row a map from the
    bodies it moves to its (3,) Jacobian (rows of the fixed base omitted). A body slid on the
    base (:func:`slid_bodies`) has none with ``kinematic_slides``; without, it is held to a
    moving carriage by a pivot and a gear (how such a joint was built before)."""
    ex, ey = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    out: list[list[Row]] = []
    for j in scene.joints:
        body = scene.body(j.body)
        parent = scene.body(j.parent) if j.parent is not None else None
        anchor = np.asarray(j.anchor, dtype=float)
        axis = np.asarray(j.axis, dtype=float)
        across = np.array([-axis[1], axis[0]])

        def rel(direction: np.ndarray, body: Body = body, parent: Body | None = parent,
                anchor: np.ndarray = anchor) -> Row:
            row = {body.name: _point_row(body, anchor, direction)}
            if parent is not None:
                row[parent.name] = -_point_row(parent, anchor, direction)
            return row

        angle: Row = {body.name: np.array([0.0, 0.0, 1.0])}
        if parent is not None:
            angle[parent.name] = np.array([0.0, 0.0, -1.0])
        if j.kind == JointKind.REVOLUTE:
            out.append([rel(ex), rel(ey)])
            if j.control == Control.VELOCITY:
                out.append([angle])
        elif parent is None and j.control == Control.VELOCITY:
            if not kinematic_slides:
                out += [[rel(ex), rel(ey)], [angle]]  # pivot and gear on a moving carriage
        else:
            out += [[rel(across)], [angle]]  # groove and gear
            if parent is not None and j.control == Control.VELOCITY:
                out.append([rel(axis)])  # the slide that drives it
    return out


def _inverse_mass(body: Body, inertia: float) -> np.ndarray:
    if body.kind != BodyKind.DYNAMIC:
        return np.zeros(3)
    return np.array([1.0 / body.mass, 1.0 / body.mass, 1.0 / inertia])


def gauss_seidel_rate(scene: Scene, inertia: dict[str, float],
                      kinematic_slides: bool = True) -> float:
    """Spectral radius ``rho`` [-] of the sweep over ``scene``'s joint constraints (module
    docstring): the fraction of its error one sweep leaves. ``inertia``: each dynamic body's
    moment of inertia about its centre of mass [kg m^2] (as the backend builds it);
    ``kinematic_slides``: as :func:`joint_rows`. 0 for a scene without two coupled joint
    constraints."""
    cons = joint_rows(scene, kinematic_slides)
    rows = [r for c in cons for r in c]
    if len(cons) < 2:
        return 0.0
    fixed = slid_bodies(scene) if kinematic_slides else set()
    w = {b.name: np.zeros(3) if b.name in fixed else _inverse_mass(b, inertia.get(b.name, 1.0))
         for b in scene.bodies}
    n = len(rows)
    a = np.zeros((n, n))
    for i, ri in enumerate(rows):
        for k, rk in enumerate(rows):
            a[i, k] = sum(float(ri[b] @ (w[b] * rk[b])) for b in ri.keys() & rk.keys())
    block = np.concatenate([[k] * len(c) for k, c in enumerate(cons)])
    lower = np.where(block[:, None] >= block[None, :], a, 0.0)  # D + L (own block included)
    upper = a - lower
    if not np.any(upper):
        return 0.0
    try:
        g = -np.linalg.solve(lower, upper)
    except np.linalg.LinAlgError:
        g = -np.linalg.lstsq(lower, upper, rcond=None)[0]
    return float(min(max(np.abs(np.linalg.eigvals(g))), 1.0))

