"""The certificate family of one contact mode: every contact-force distribution its force stage
admits, and how far observed forces are from it.

For a mode (codes and sliding directions ``xi``) of a system at friction ``mu`` the force stage
asks for contact forces ``c = (c_1n, c_1t, ..., c_nn, c_nt)`` with

* equilibrium of the workpiece and of the effort-controlled joints, eq. (26):
  ``G^T c = [-g_obj; tau_I - g_man_I]`` with ``G = [W^T  J_E]`` (eqs. 2-3);
* Coulomb's law per contact, eqs. (17), (21)-(22): rolling ``|c_it| <= mu_i c_in``,
  ``c_in >= 0``; sliding ``c_it = -mu_i xi_i c_in``, ``c_in >= 0``; breaking ``c_i = 0``.

A force-determinate mode has one such ``c`` (its certificate); a force-indeterminate one
(relaxed utility, end of Sec. 3.2) a polytope of them. :func:`nearest_certificate` solves one
linear program (scipy HiGHS) for the member nearest to observed forces (largest component
difference), optionally with some contacts required to carry no load -- which answers whether a
simulator run whose contact carries zero force (and so reads as "breaking") is still
consistent with the predicted mode: it is when the family holds a member with zero force there.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from planner.errors import InputError
from planner.model.modes import BREAK, ROLL, SLIDE, Mode
from planner.model.system import System
from planner.predict.setup import system_setup

__all__ = ["FamilyFit", "admits_unloaded", "nearest_certificate"]


@dataclass(frozen=True, eq=False)
class FamilyFit:
    """The member of a mode's certificate family nearest to observed forces: ``forces``
    ``(n_c, 2)`` [N] ``(c_in, c_it)`` in the contact frames, and ``distance`` [N], the largest
    ``|c - c_observed|`` over the components (0 without observed forces)."""

    forces: np.ndarray
    distance: float


def nearest_certificate(system: System, mode: Mode, observed: np.ndarray | None = None, *,
                        unloaded: Iterable[int] = (), at_most: float = 0.0
                        ) -> FamilyFit | None:
    """The member of ``mode``'s certificate family (module docstring) nearest to ``observed``
    ``(n_c, 2)`` [N] forces, in the largest-component sense; with ``observed`` None any member.
    ``unloaded``: 0-based contacts whose normal force must be zero, or with ``at_most`` > 0
    [N] at most that (their tangential force stays in the mode's Coulomb constraints). ``None``
    when the family is empty (the mode is not feasible at the system's friction, or not with
    those contacts unloaded). ``mode`` must have ``system.n_contacts`` contacts."""
    n_c = system.n_contacts
    if len(mode.codes) != n_c:
        raise InputError(f"mode: expected {n_c} contacts, got {len(mode.codes)} "
                         f"({mode.label!r})")
    zero = {int(i) for i in unloaded}
    if any(not 0 <= i < n_c for i in zero):
        raise InputError(f"unloaded: expected contact indices in [0, {n_c}), got {sorted(zero)}")
    if not (np.isfinite(at_most) and at_most >= 0.0):
        raise InputError(f"at_most: expected a finite force >= 0 N, got {at_most!r}")
    setup = system_setup(system)[1]
    G, rs, rhs = setup.G, setup.rs, setup.rhs
    mu = np.asarray(system.mu, dtype=float)
    n = 2 * n_c
    # variables x = [c (2 n_c), t]; equilibrium rows scaled like the force stage's (rs)
    A_eq = [np.hstack([(G / rs).T, np.zeros((G.shape[1], 1))])]
    b_eq = [rhs / rs]
    A_ub: list[np.ndarray] = []
    bounds: list[tuple[float | None, float | None]] = [(None, None)] * n + [(0.0, None)]
    for i, (code, xi) in enumerate(zip(mode.codes, mode.xi)):
        jn, jt = 2 * i, 2 * i + 1
        if code == BREAK:
            bounds[jn] = bounds[jt] = (0.0, 0.0)
        elif i in zero:
            bounds[jn] = (0.0, float(at_most))
        else:
            bounds[jn] = (0.0, None)
        if code == ROLL:
            for sign in (1.0, -1.0):  # -(mu c_n -+ c_t) <= 0
                row = np.zeros(n + 1)
                row[jn], row[jt] = -mu[i], sign
                A_ub.append(row)
        elif code == SLIDE:  # c_t + mu xi c_n = 0
            row = np.zeros(n + 1)
            row[jt], row[jn] = 1.0, mu[i] * float(xi)
            A_eq.append(row[None])
            b_eq.append(np.zeros(1))
    b_ub = [0.0] * len(A_ub)
    objective = np.zeros(n + 1)
    if observed is not None:
        obs = np.asarray(observed, dtype=float).reshape(-1)
        if obs.shape != (n,) or not np.all(np.isfinite(obs)):
            raise InputError(f"observed: expected ({n_c}, 2) finite forces, got shape "
                             f"{np.shape(observed)}")
        for j in range(n):  # |c_j - obs_j| <= t
            for sign in (1.0, -1.0):
                row = np.zeros(n + 1)
                row[j], row[n] = sign, -1.0
                A_ub.append(row)
                b_ub.append(sign * obs[j])
        objective[n] = 1.0
    else:
        bounds[n] = (0.0, 0.0)
    res = linprog(objective, A_ub=np.array(A_ub).reshape(-1, n + 1) if A_ub else None,
                  b_ub=np.array(b_ub) if A_ub else None, A_eq=np.vstack(A_eq),
                  b_eq=np.concatenate(b_eq), bounds=bounds, method="highs")
    if res.status != 0:
        return None
    c = np.asarray(res.x[:n], dtype=float).reshape(n_c, 2)
    return FamilyFit(c, float(res.x[n]) if observed is not None else 0.0)


def admits_unloaded(system: System, mode: Mode, contacts: Iterable[int],
                    at_most: float = 0.0) -> bool:
    """True when ``mode``'s certificate family holds a member with zero normal force (at most
    ``at_most`` [N]) at every one of ``contacts`` (0-based) at once."""
    return nearest_certificate(system, mode, unloaded=contacts, at_most=at_most) is not None
