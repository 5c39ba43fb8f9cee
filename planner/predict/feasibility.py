"""Feasibility of contact modes, batched: eqs. (13)-(28) of Trinkle & Zeng (1994).

For every candidate mode (``2 n_R + n_S = 3 + |tau_I|``, Section 4.7) the kinematic stage
solves ``P_AI zdot_I = -P_AII zdot_II`` (eqs. 23-24) for the workpiece velocity ``qdot`` and the
velocities of the effort-controlled joints, then checks that breaking contacts separate (eq. 25)
and fixes the sliding directions ``xi = sgn(v_t)`` (eq. 16).  The force stage solves
``Q_AI c_A = [-g_obj; tau_I - g_man_I]`` (eq. 26) with ``W_Amu`` of eqs. (18)-(19), recovers the
efforts of the velocity-controlled joints (eq. 27) and checks the Coulomb inequalities
``B_A c_A >= 0`` (eqs. 21-22, 28).  All candidates go through both stages as stacked arrays; there
is no per-mode Python loop on this path.

Statically indeterminate modes (relaxed utility, end of Section 3.2: more kinematic constraints
than ``3 + |tau_I|``, e.g. ``2R`` on one rigid link) are handled by :func:`indeterminate_modes`:
the velocities come from a consistent over-determined system (unique ``qdot`` required), the
forces from a linear program over the null space of ``Q_A`` (the generalised-inverse route).

Tolerance policy (``docs/conventions.md``): every constraint is normalised -- velocities by the
largest commanded contact-point speed, forces by the largest applicable force of the mode -- and
the smallest normalised slack is the mode's ``margin``.  Closed constraints (Coulomb, eq. 28) pass
when ``margin >= -tol`` and the mode is flagged ``on_boundary`` when ``|margin| <= tol``.  Strict
kinematic constraints (breaking contacts separate, sliding contacts slip) need ``margin > tol``;
modes that miss them by at most ``tol`` are listed in :attr:`Prediction.boundary_modes`.
Matrices whose equilibrated determinant is below ``singular_tol`` violate the rank conditions
(30)-(32) and the mode is counted as ``degenerate``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.modes import (
    CandidateSet,
    Mode,
    candidate_count,
    enumerate_modes,
)
from planner.model.system import System
from planner.model.validation import as_friction
from planner.predict.indeterminate import indeterminate_modes
from planner.predict.stages import (
    DEFAULT_SINGULAR_TOL,
    DEFAULT_TOL,
    FeasibleMode,
    force_stage,
    kinematic_stage,
)

#: Above this many contacts the relaxed (force-indeterminate) search is off unless asked for.
INDETERMINATE_AUTO_MAX_CONTACTS = 8


class Status(str, Enum):
    """Outcome of a prediction (Sections 4.1, 4.3).

    ``UNIQUE``: one feasible mode. ``AMBIGUOUS``: several (Sec. 4.3). ``JAMMED``: none (the
    "Jam" regions of Fig. 3). ``AT_REST``: every commanded joint velocity is zero, so no
    contact can slide or break; the listed modes (all rolling, ``qdot = 0``) are the static
    equilibria that hold. ``NO_CANDIDATES``: the utility conditions admit no mode at all
    (``n_c < (3 + |tau_I|) / 2``, Sec. 4.7).
    """

    UNIQUE = "unique"
    AMBIGUOUS = "ambiguous"
    JAMMED = "jammed"
    AT_REST = "at_rest"
    NO_CANDIDATES = "no_candidates"


@dataclass(frozen=True, eq=False)
class Prediction:
    """All feasible modes of one system at one friction vector.

    ``status`` counts determinate and force-indeterminate feasible modes together.
    """

    status: Status
    candidates: int
    modes: tuple[FeasibleMode, ...]
    indeterminate_modes: tuple[FeasibleMode, ...] = ()
    boundary_modes: tuple[Mode, ...] = ()
    degenerate: int = 0
    tol: float = DEFAULT_TOL
    mu: np.ndarray = field(default_factory=lambda: np.zeros(0))
    reason: str = ""

    @property
    def all_modes(self) -> tuple[FeasibleMode, ...]:
        return self.modes + self.indeterminate_modes

    @property
    def labels(self) -> list[str]:
        """Mode strings of every feasible mode (determinate first)."""
        return [m.label for m in self.all_modes]

    @property
    def on_boundary(self) -> bool:
        """True when any decision was within ``tol`` of a boundary."""
        return bool(self.boundary_modes) or any(m.on_boundary for m in self.all_modes)

    def find(self, label: str) -> FeasibleMode | None:
        """The feasible mode with this label, or None."""
        for m in self.all_modes:
            if m.label == label:
                return m
        return None

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": self.status.value,
            "candidates": int(self.candidates),
            "mu": self.mu.tolist(),
            "modes": [m.to_dict() for m in self.all_modes],
            "boundary_modes": [m.label for m in self.boundary_modes],
            "degenerate_candidates": int(self.degenerate),
            "reason": self.reason,
        }
# Public entry point.
# ---------------------------------------------------------------------------------------------
def feasible_modes(
    system: System,
    mu: Any = None,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    indeterminate: bool | None = None,
) -> Prediction:
    """Every feasible contact mode of ``system`` with its certificate (eqs. 13-32).

    Parameters
    ----------
    system : System
    mu : float or (n_c,), optional
        Friction coefficients; defaults to ``system.mu``.
    tol : float
        Relative tolerance of the boundary policy (module docstring).
    singular_tol : float
        Equilibrated-determinant threshold for the rank conditions (30)-(32).
    indeterminate : bool, optional
        Also search the relaxed-utility (force-indeterminate) modes. Default: only when
        ``n_c <= 8``.

    Returns
    -------
    Prediction
        ``status`` is ``unique`` (one feasible mode), ``ambiguous`` (several, Section 4.3)
        or ``jammed`` (none).
    """
    if not isinstance(system, System):
        raise InputError(f"system: expected a planner System, got {type(system).__name__}")
    mu_arr = system.mu if mu is None else as_friction(mu, system.n_contacts)
    if not (np.isfinite(tol) and tol >= 0):
        raise InputError(f"tol: expected a finite number >= 0, got {tol}")
    cand = enumerate_modes(system.n_contacts, system.dof)
    prediction, _ = predict_candidates(
        system, cand, mu_arr, tol=tol, singular_tol=singular_tol, indeterminate=indeterminate
    )
    return prediction


def predict_candidates(
    system: System,
    cand: CandidateSet,
    mu_arr: np.ndarray,
    *,
    tol: float,
    singular_tol: float,
    indeterminate: bool | None,
) -> tuple[Prediction, int]:
    """Kinematic then force stage on the candidates ``cand`` and the :class:`Prediction`
    (eqs. 23-28); also the number of candidates that reached the force stage.

    ``cand`` is every eq. (49) candidate for :func:`feasible_modes`, and the candidates that
    survive the pruning for :func:`planner.predict.search.search_modes` (same arithmetic per
    candidate, same assembly); ``candidates`` in the result is always the eq. (49) count.
    """
    kin = kinematic_stage(system, cand, tol=tol, singular_tol=singular_tol)
    idx = np.flatnonzero(kin.ok)
    fs = force_stage(system, cand, idx, kin.xi[idx], mu_arr, singular_tol=singular_tol)
    margin = np.minimum(fs.margin[0], kin.margin[idx])
    feasible = fs.nonsingular[0] & (margin >= -tol)
    finite = np.isfinite(kin.qdot[idx]).all(axis=1) & np.isfinite(fs.c_A[0]).all(axis=1)
    if np.any(fs.nonsingular[0] & ~finite):
        raise DegenerateError(
            "numerical overflow while solving eqs. (24)/(26): expected inputs whose magnitudes "
            "fit in double precision products (rescale lengths, forces or speeds)"
        )
    modes = []
    for j in np.flatnonzero(feasible):
        i = idx[j]
        modes.append(
            FeasibleMode(
                mode=Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in kin.xi[i])),
                qdot=kin.qdot[i].copy(),
                joint_velocities=kin.joint_velocities[i].copy(),
                contact_velocities=kin.v[i].reshape(-1, 2).copy(),
                contact_forces=fs.contact_forces[0, j].copy(),
                joint_efforts=fs.joint_efforts[0, j].copy(),
                margin=float(margin[j]),
                on_boundary=bool(abs(margin[j]) <= tol),
            )
        )
    boundary = tuple(
        Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in kin.xi[i]))
        for i in np.flatnonzero(kin.boundary)
    )
    degenerate = int(np.count_nonzero(~kin.nonsingular)) + int(
        np.count_nonzero(~fs.nonsingular[0])
    )
    if indeterminate is None:
        indeterminate = system.n_contacts <= INDETERMINATE_AUTO_MAX_CONTACTS
    extra: tuple[FeasibleMode, ...] = ()
    if indeterminate:
        extra = tuple(indeterminate_modes(system, mu_arr, tol=tol, singular_tol=singular_tol))
    n_feasible = len(modes) + len(extra)
    n_cand = candidate_count(system.n_contacts, system.dof)
    if n_cand == 0:
        status = Status.NO_CANDIDATES
        reason = (
            f"the utility conditions (29)-(32) admit no mode: {system.n_contacts} contact(s) "
            f"cannot supply 2 n_R + n_S = {system.dof} kinematic constraints"
        )
    elif kin.velocity_scale == 0.0:
        status = Status.AT_REST
        reason = (
            "every commanded joint velocity is zero: nothing slides or breaks; "
            + (f"{n_feasible} static equilibrium mode(s) hold" if n_feasible else
               "no static equilibrium holds")
        )
    elif n_feasible == 0:
        status = Status.JAMMED
        reason = "no candidate mode is feasible" + (
            f" ({degenerate} candidate(s) violate the rank conditions (30)-(32))"
            if degenerate else ""
        )
    else:
        status = Status.UNIQUE if n_feasible == 1 else Status.AMBIGUOUS
        reason = f"{n_feasible} feasible mode(s)"
    if boundary or any(m.on_boundary for m in modes + list(extra)):
        reason += "; some decisions are within tolerance of a boundary"
    prediction = Prediction(
        status=status,
        candidates=n_cand,
        modes=tuple(modes),
        indeterminate_modes=extra,
        boundary_modes=boundary,
        degenerate=degenerate,
        tol=tol,
        mu=np.array(mu_arr, dtype=float),
        reason=reason,
    )
    return prediction, len(idx)
