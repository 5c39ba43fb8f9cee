"""The workpiece's uncertain mass and centre of mass: the vertices of its load set (eq. 2).

The planner's external wrench on a workpiece (eq. 2) is the load force ``f`` at the centre of mass
``c`` (body frame), about the world origin at pose ``(x, y, phi)``::

    g_obj = [f_x, f_y, r_x f_y - r_y f_x],   r = R(phi) c + (x, y).

The load is taken proportional to the mass (``f = m a`` with ``a = f_0 / m_0`` fixed: gravity, or a
table's support friction proportional to the weight), so ``g_obj`` is *linear* in
``theta = (m, m c_x, m c_y)``::

    g_obj = m [a; (x, y) x a] + (m R c) x a       (x: the planar cross product).

A mass interval ``[m_lo, m_hi]`` (``m_lo > 0``) and a centre-of-mass box ``C`` give the set
``Theta = {(m, m c) : m in [m_lo, m_hi], c in C}``.  ``Theta`` is convex (the perspective of ``C``
cut by the slab: ``(m, y) in Theta`` iff ``m_lo <= m <= m_hi`` and ``m c_lo <= y <= m c_hi``, linear
inequalities) and its vertices are ``(m, m c)`` for ``m`` an end of the interval and ``c`` a corner
of ``C`` -- at most 8 points.  The load set ``{g_obj}`` is the image of ``Theta`` under a linear
map, hence the convex hull of the wrenches at those vertices (:meth:`LoadSet.vertices`).  Why that
is enough for the guarantees and where it is not: docs/planning.md, "Uncertainty beyond friction".

Units: kg, m (body frame), N, N m.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from planner.errors import InputError


@dataclass(frozen=True)
class LoadSet:
    """The workpiece's mass interval ``mass = (lo, hi)`` [kg] and centre-of-mass box
    ``com = ((x_lo, x_hi), (y_lo, y_hi))`` [m, body frame] around the nominal ``nominal_mass``
    and ``nominal_com`` (the hand file's ``workpiece.mass`` and ``workpiece.com``)."""

    mass: tuple[float, float]
    com: tuple[tuple[float, float], tuple[float, float]]
    nominal_mass: float
    nominal_com: tuple[float, float]

    def __post_init__(self) -> None:
        lo, hi = self.mass
        if not (np.isfinite(lo) and np.isfinite(hi) and 0.0 < lo <= self.nominal_mass <= hi):
            raise InputError(f"mass interval: expected 0 < lo <= {self.nominal_mass:g} (the "
                             f"workpiece's mass) <= hi, finite, got [{lo:g}, {hi:g}]")
        for k, axis in enumerate("xy"):
            a, b = self.com[k]
            if not (np.isfinite(a) and np.isfinite(b) and a <= self.nominal_com[k] <= b):
                raise InputError(f"centre-of-mass box: expected {axis}_lo <= "
                                 f"{self.nominal_com[k]:g} (the workpiece's com.{axis}) <= "
                                 f"{axis}_hi, finite, got [{a:g}, {b:g}]")

    @property
    def trivial(self) -> bool:
        """True when the set is the nominal point (the plan is today's friction-only one)."""
        return (self.mass[0] == self.mass[1] == self.nominal_mass
                and all(self.com[k][0] == self.com[k][1] == self.nominal_com[k]
                        for k in range(2)))

    def points(self) -> np.ndarray:
        """``(K, 3)`` the distinct vertices ``(m, c_x, c_y)`` of ``Theta`` (module docstring):
        each end of the mass interval with each corner of the box; ``K <= 8``."""
        pts = itertools.product(sorted(set(self.mass)), sorted(set(self.com[0])),
                                sorted(set(self.com[1])))
        return np.array(list(pts), dtype=float)

    def vertices(self, load_force: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """``(K, 3)`` the external wrench (eq. 2) about the world origin at each vertex of
        ``Theta``, for the nominal load ``load_force (2,)`` [N] and the pose ``(x, y, phi)``."""
        f0 = np.asarray(load_force, dtype=float)
        c, s = np.cos(pose[2]), np.sin(pose[2])
        out = []
        for m, cx, cy in self.points():
            f = f0 * (m / self.nominal_mass)
            r = np.array([c * cx - s * cy + pose[0], s * cx + c * cy + pose[1]])
            out.append([f[0], f[1], r[0] * f[1] - r[1] * f[0]])
        return np.array(out, dtype=float)

    def widened(self, axis: str, half: float) -> LoadSet:
        """The set with ``axis`` (``"mass"`` [kg] or ``"com"`` [m, both coordinates]) replaced
        by the symmetric interval ``nominal +- half`` (the other axis kept); a mass interval is
        cut at ``1e-9`` of the nominal mass (masses stay positive)."""
        if axis == "mass":
            m0 = self.nominal_mass
            return LoadSet((max(m0 - half, 1e-9 * m0), m0 + half), self.com, m0,
                           self.nominal_com)
        if axis == "com":
            cx, cy = self.nominal_com
            return LoadSet(self.mass, ((cx - half, cx + half), (cy - half, cy + half)),
                           self.nominal_mass, self.nominal_com)
        raise InputError(f"axis: expected 'mass' or 'com', got {axis!r}")

    def to_dict(self) -> dict[str, list]:
        """The hand file's ``uncertainty`` section (docs/file-formats.md)."""
        return {"mass": list(self.mass), "com": [list(self.com[0]), list(self.com[1])]}


def point_set(mass: float, com: np.ndarray) -> LoadSet:
    """The nominal point: the friction-only plan."""
    c = (float(com[0]), float(com[1]))
    return LoadSet((mass, mass), ((c[0], c[0]), (c[1], c[1])), mass, c)
