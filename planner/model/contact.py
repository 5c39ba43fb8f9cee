"""One point contact given by its point, inward normal and friction coefficient (eq. 1)."""

from __future__ import annotations

from dataclasses import dataclass

from planner.model.validation import as_array, as_friction, unit_normal


@dataclass(frozen=True)
class Contact:
    """One point contact given geometrically.

    Parameters
    ----------
    point : (2,) [m]
        Contact point ``r_i`` in the world frame.
    normal : (2,)
        Unit contact normal ``n_i`` pointing into the workpiece, world frame.
    mu : float
        Coulomb friction coefficient ``mu_i >= 0``.
    """

    point: tuple[float, float]
    normal: tuple[float, float]
    mu: float

    def __post_init__(self) -> None:
        p = as_array(self.point, (2,), "contact point")
        n = unit_normal(self.normal, "contact normal")
        mu = as_friction(self.mu, 1, "contact mu")[0]
        object.__setattr__(self, "point", (float(p[0]), float(p[1])))
        object.__setattr__(self, "normal", (float(n[0]), float(n[1])))
        object.__setattr__(self, "mu", float(mu))

    @property
    def tangent(self) -> tuple[float, float]:
        """``t_i = rot90(n_i)``, so that ``n_i x t_i = +1`` (eq. 1)."""
        return (-self.normal[1], self.normal[0])
