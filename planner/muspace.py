"""Decomposition of a box of friction space into regions labelled by their feasible-mode set.

Implements the friction-space maps of Trinkle & Zeng (1994), Figures 3 and 6, through the
general feasibility test (eqs. 26-28): the friction-independent kinematic stage (eqs. 13-16,
23-25) runs once, then the force stage runs for all grid points at once (``mu`` shaped
``(L, n_c)``).  Closed-form regions (App. A/B, eqs. 50-60) are not implemented yet (issue 3,
open).

Differences to the paper: labels carry the sliding direction (``S+``/``S-``) as in
``docs/conventions.md``; modes within ``tol`` of a strict kinematic constraint are excluded.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.feasibility import DEFAULT_TOL, force_stage, kinematic_stage
from planner.model import System
from planner.modes import Mode, enumerate_modes


@dataclass(frozen=True, eq=False)
class MuGrid:
    """A labelled grid of friction space.

    Attributes
    ----------
    vary : tuple[int, ...]        0-based contact indices varied (1 or 2), axis order.
    axes : tuple[(n_a,), ...]     grid values of each varied coefficient [-].
    base_mu : (n_c,)              values of the coefficients not varied.
    labels : tuple[str, ...]      feasible mode labels (the union over the grid).
    feasible : (L, n_modes) bool  mode j feasible at grid point l (C order over the axes).
    """

    vary: tuple[int, ...]
    axes: tuple[np.ndarray, ...]
    base_mu: np.ndarray
    labels: tuple[str, ...]
    feasible: np.ndarray

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.axes)

    def mode_sets(self) -> np.ndarray:
        """Mode-set label per grid point, shape ``self.shape``; ``"jam"`` where none holds."""
        out = np.empty(self.feasible.shape[0], dtype=object)
        for i, row in enumerate(self.feasible):
            names = [lab for lab, f in zip(self.labels, row) if f]
            out[i] = " | ".join(names) if names else "jam"
        return out.reshape(self.shape)

    def to_dict(self) -> dict[str, Any]:
        return {
            "vary": [i + 1 for i in self.vary],
            "axes": [a.tolist() for a in self.axes],
            "base_mu": self.base_mu.tolist(),
            "labels": list(self.labels),
            "feasible": self.feasible.astype(int).tolist(),
        }

    @staticmethod
    def from_dict(d: dict[str, Any]) -> MuGrid:
        return MuGrid(
            vary=tuple(int(i) - 1 for i in d["vary"]),
            axes=tuple(np.asarray(a, float) for a in d["axes"]),
            base_mu=np.asarray(d["base_mu"], float),
            labels=tuple(d["labels"]),
            feasible=np.asarray(d["feasible"], bool),
        )


def _check_range(lo: float, hi: float) -> None:
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise InputError(f"mu range: expected finite bounds, got {lo}:{hi}")
    if lo > hi:
        raise InputError(f"mu range: expected min <= max, got min {lo} > max {hi}")
    if lo < 0:
        raise InputError(f"mu range: expected mu >= 0, got min {lo}")


def mu_grid(
    system: System,
    vary: tuple[int, ...],
    base_mu: Any,
    mu_range: tuple[float, float] = (0.0, 1.0),
    n: int = 100,
    *,
    tol: float = DEFAULT_TOL,
) -> MuGrid:
    """Label an ``n^len(vary)`` grid of the coefficients ``vary`` (0-based) by the general test.

    Parameters
    ----------
    vary : 0-based contact indices (1 or 2 of them) whose coefficient spans ``mu_range``.
    base_mu : (n_c,) values of all coefficients; entries in ``vary`` are overwritten.
    """
    n_c = system.n_contacts
    vary = tuple(int(i) for i in vary)
    if not 1 <= len(vary) <= 2 or len(set(vary)) != len(vary):
        raise InputError(f"vary: expected 1 or 2 distinct contacts, got {[i + 1 for i in vary]}")
    for i in vary:
        if not 0 <= i < n_c:
            raise InputError(f"vary: expected contact index in 1..{n_c}, got {i + 1}")
    base = np.asarray(base_mu, dtype=float).reshape(-1)
    if base.shape != (n_c,):
        raise InputError(f"base_mu: expected shape ({n_c},), got {base.shape}")
    if np.any(base < 0) or not np.all(np.isfinite(base)):
        raise InputError(f"base_mu: expected finite mu >= 0, got {base.tolist()}")
    _check_range(*mu_range)
    if n < 1:
        raise InputError(f"n: expected >= 1 grid points per axis, got {n}")
    axes = tuple(np.linspace(mu_range[0], mu_range[1], n) for _ in vary)
    mesh = np.meshgrid(*axes, indexing="ij")
    mu = np.tile(base, (mesh[0].size, 1))
    for j, i in enumerate(vary):
        mu[:, i] = mesh[j].ravel()
    cand = enumerate_modes(n_c, system.dof)
    kin = kinematic_stage(system, cand, tol=tol)
    index = np.flatnonzero(kin.ok)
    labels = tuple(
        Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in kin.xi[i])).label
        for i in index
    )
    if index.size:
        fs = force_stage(system, cand, index, kin.xi[index], mu)
        feas = fs.nonsingular & (fs.margin >= -tol)
    else:
        feas = np.zeros((mu.shape[0], 0), bool)
    keep = np.any(feas, axis=0)
    return MuGrid(vary, axes, base, tuple(lab for lab, k in zip(labels, keep) if k),
                  feas[:, keep])
