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

Contact positions.  The set may also move each contact along its feature: ``contact_offset``
[m] (every contact ``+-`` that distance) and ``body_offsets`` (per body the contact touches
besides the workpiece -- ``"palm"``, a surface's or a finger's name -- its own half-width,
overriding ``contact_offset``).  :meth:`offsets` resolves them for a contact set; the planner
takes the box's vertices (:mod:`planner.plan.offset_bounds`; why vertices suffice:
docs/planning.md, "Contact positions").

Units: kg, m (body frame), N, N m.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from typing import Any

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
    contact_offset: float = 0.0
    body_offsets: tuple[tuple[str, float], ...] = ()

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
        for name, d in (("contacts", self.contact_offset),
                        *((f"contacts.{n}", d) for n, d in self.body_offsets)):
            if not (np.isfinite(d) and d >= 0.0):
                raise InputError(f"{name}: expected a half-width >= 0 [m], finite, got {d:g}")

    @property
    def trivial(self) -> bool:
        """True when the mass and centre of mass are the nominal point (the load is the
        nominal wrench; contact offsets are :attr:`has_offsets`)."""
        return (self.mass[0] == self.mass[1] == self.nominal_mass
                and all(self.com[k][0] == self.com[k][1] == self.nominal_com[k]
                        for k in range(2)))

    @property
    def has_offsets(self) -> bool:
        """True when some contact may move along its feature."""
        return self.contact_offset > 0.0 or any(d > 0.0 for _, d in self.body_offsets)

    def offsets(self, bodies: tuple[str, ...]) -> np.ndarray:
        """``(n_c,)`` the half-width [m] of each contact's position along its feature, for the
        contacts touching ``bodies`` (one name per contact): its body's entry of
        :attr:`body_offsets`, else :attr:`contact_offset`."""
        own = dict(self.body_offsets)
        return np.array([own.get(b, self.contact_offset) for b in bodies], dtype=float)

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
        """The set with ``axis`` (``"mass"`` [kg], ``"com"`` [m, both coordinates] or
        ``"contacts"`` [m, every contact]) replaced by the symmetric interval ``nominal +-
        half`` (the other axes kept); a mass interval is cut at ``1e-9`` of the nominal mass
        (masses stay positive)."""
        if axis == "mass":
            m0 = self.nominal_mass
            return replace(self, mass=(max(m0 - half, 1e-9 * m0), m0 + half))
        if axis == "com":
            cx, cy = self.nominal_com
            return replace(self, com=((cx - half, cx + half), (cy - half, cy + half)))
        if axis == "contacts":
            return replace(self, contact_offset=float(half), body_offsets=())
        raise InputError(f"axis: expected 'mass', 'com' or 'contacts', got {axis!r}")

    def to_dict(self) -> dict[str, Any]:
        """The hand file's ``uncertainty`` section (docs/file-formats.md); ``contacts`` only
        when some contact may move."""
        out: dict[str, Any] = {"mass": list(self.mass),
                               "com": [list(self.com[0]), list(self.com[1])]}
        if self.body_offsets:
            out["contacts"] = {n: d for n, d in self.body_offsets}
            if self.contact_offset > 0.0:
                out["contacts"]["*"] = self.contact_offset
        elif self.contact_offset > 0.0:
            out["contacts"] = self.contact_offset
        return out


def point_set(mass: float, com: np.ndarray) -> LoadSet:
    """The nominal point: the friction-only plan."""
    c = (float(com[0]), float(com[1]))
    return LoadSet((mass, mass), ((c[0], c[0]), (c[1], c[1])), mass, c)
