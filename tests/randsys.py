"""Seeded random systems for property tests (contacts on a random convex ellipse)."""

from __future__ import annotations

import numpy as np

from planner import System


def random_geometry(rng, n_c, scale=1.0):
    a, b = rng.uniform(0.5, 2.0, size=2) * scale
    ang = np.sort(rng.uniform(0, 2 * np.pi, n_c))
    pts = np.c_[a * np.cos(ang), b * np.sin(ang)] + rng.normal(0, 0.2 * scale, 2)
    out = np.c_[np.cos(ang) / a, np.sin(ang) / b]  # outward normal of the ellipse
    nrm = -out / np.linalg.norm(out, axis=1, keepdims=True)
    return pts, nrm


def random_system(rng, n_c, n_effort=0, n_velocity=None, scale=1.0, virtual=None):
    """A random system; ``virtual`` -> contact-velocity form, else random Jacobian with joints."""
    pts, nrm = random_geometry(rng, n_c, scale)
    mu = rng.uniform(0.0, 0.8, n_c)
    g = np.r_[rng.normal(0, 1, 2), rng.normal(0, scale)]
    if virtual is None:
        virtual = n_effort == 0 and rng.random() < 0.5
    if virtual:
        return System.from_contacts(
            points=pts, normals=nrm, mu=mu, external_wrench=g,
            contact_velocities=rng.normal(0, 1, (n_c, 2)),
        )
    n_v = n_velocity if n_velocity is not None else int(rng.integers(1, 3))
    n_t = n_effort + n_v
    J = rng.normal(0, 1, (n_c, 2, n_t)) * np.r_[np.full(n_effort, scale), np.ones(n_v)]
    order = rng.permutation(n_t)
    joints = []
    for j in order:
        if j < n_effort:
            joints.append({"effort": float(rng.normal(0, 2) * scale)})
        else:
            joints.append({"velocity": float(rng.normal(0, 1))})
    return System.from_contacts(
        points=pts, normals=nrm, mu=mu, external_wrench=g,
        jacobian=J[:, :, order], joints=joints, joint_loads=rng.normal(0, 0.3, n_t) * scale,
    )
