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
modes that miss them by at most ``tol``, forces passing eq. (28), are ``boundary_modes``.
Matrices whose equilibrated determinant is below ``singular_tol`` violate the rank conditions
(30)-(32) and the mode is counted as ``degenerate``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.modes import (
    CandidateSet,
    Mode,
    candidate_count,
    candidates_from_codes,
    enumerate_modes,
    frictionless_duplicates_removed,
    iter_candidate_codes,
)
from planner.model.system import System
from planner.model.validation import as_friction
from planner.predict.boundary import boundary_modes_of
from planner.predict.indeterminate import (
    DEFAULT_MAX_ROW_SUBSETS,
    GEN_TOL,
    IndeterminateKinematics,
    closed_bases_suffice,
    codes_from_velocities,
    generation_thresholds,
    indeterminate_kinematics_of,
    indeterminate_modes,
    scan_indeterminate,
)
from planner.predict.stages import (
    DEFAULT_SINGULAR_TOL,
    DEFAULT_TOL,
    FeasibleMode,
    KinematicStage,
    equilibrated_kinematics,
    force_stage,
    kinematic_stage,
)

#: Elements of the per-chunk velocity array ``(chunk, 2 n_c)``: more candidates are streamed.
STREAM_ELEMENTS = 1 << 22
#: Largest eq. (49) count :func:`feasible_modes` enumerates (larger: use search_modes).
MAX_EXHAUSTIVE_CANDIDATES = 200_000_000
#: ``Prediction.limits`` entry when the relaxed-utility pass was switched off.
INDETERMINATE_OFF = "force-indeterminate (relaxed-utility) modes not searched (indeterminate=False)"


def stream_chunk(n_contacts: int) -> int:
    """Candidates per chunk of the streamed exhaustive enumeration at ``n_c`` contacts."""
    return max(256, STREAM_ELEMENTS // max(2 * n_contacts, 1))


class Status(str, Enum):
    """Outcome of a prediction (Secs. 4.1, 4.3); each documented in docs/conventions.md,
    "Statuses": ``UNIQUE`` one feasible mode, ``AMBIGUOUS`` several, ``JAMMED`` none while
    driven, ``AT_REST`` undriven with a static equilibrium, ``MOVING`` undriven without one (the
    load accelerates it, :attr:`Prediction.unbalanced`), ``NO_CANDIDATES`` no mode (Sec. 4.7).
    """

    UNIQUE = "unique"
    AMBIGUOUS = "ambiguous"
    JAMMED = "jammed"
    AT_REST = "at_rest"
    MOVING = "moving"
    NO_CANDIDATES = "no_candidates"


@dataclass(frozen=True, eq=False)
class Prediction:
    """All feasible modes of one system at one friction vector.

    ``status`` counts determinate and force-indeterminate feasible modes together.
    ``limits`` lists every class of candidates that was not searched (empty: the prediction
    is complete; otherwise ``reason`` says so too), ``method`` how the determinate candidates
    were enumerated (``exhaustive``, ``exhaustive, streamed in N chunks`` or ``search``).
    ``unbalanced`` ``(3 n_b,)`` [N, N, N m]: with status ``moving``, the load no contact force
    within the friction cones balances (:mod:`planner.predict.unbalanced`); else None.
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
    limits: tuple[str, ...] = ()
    method: str = "exhaustive"
    unbalanced: np.ndarray | None = None

    @property
    def complete(self) -> bool:
        """True when every candidate class was searched (``limits`` is empty)."""
        return not self.limits

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
            "complete": self.complete,
            "limits": list(self.limits),
            "method": self.method,
            **({} if self.unbalanced is None else {"unbalanced_load": self.unbalanced.tolist()}),
        }


def feasible_modes(
    system: System,
    mu: Any = None,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    indeterminate: bool | None = None,
    max_subsets: int = DEFAULT_MAX_ROW_SUBSETS,
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
        Search the relaxed-utility (force-indeterminate) modes (end of Sec. 3.2) too, at any
        ``n_c`` (:func:`planner.predict.indeterminate.scan_indeterminate`).  Default (None):
        yes while ``C(2 n_c, 3 + |tau_I|) <= max_subsets``; True: regardless of the cost;
        False: no.  Whatever is not searched is named in ``Prediction.limits``.
    max_subsets : int
        Row-subset budget of the relaxed-utility pass when ``indeterminate`` is None.

    Returns
    -------
    Prediction
        ``status`` (:class:`Status`); ``limits`` is empty when nothing was skipped.  More than
        :data:`STREAM_ELEMENTS` ``/ 2 n_c`` candidates are streamed in chunks (``method``
        says so); more than :data:`MAX_EXHAUSTIVE_CANDIDATES` are refused (InputError).
    """
    if not isinstance(system, System):
        raise InputError(f"system: expected a planner System, got {type(system).__name__}")
    mu_arr = system.mu if mu is None else as_friction(mu, system.n_contacts)
    if not (math.isfinite(tol) and tol >= 0):
        raise InputError(f"tol: expected a finite number >= 0, got {tol}")
    n_c, k = system.n_contacts, system.dof
    n_cand = candidate_count(n_c, k)
    if n_cand > MAX_EXHAUSTIVE_CANDIDATES:
        raise InputError(
            f"feasible_modes: expected at most {MAX_EXHAUSTIVE_CANDIDATES} candidate modes "
            f"(eq. 49) for exhaustive enumeration, got {n_cand} (n_c = {n_c}, 3 n_b + |tau_I| = "
            f"{k}); use planner.predict.search.search_modes (qsplan modes --search)"
        )
    chunk = stream_chunk(n_c)
    # Relaxed-utility modes from the determinate candidates' velocities when the structural
    # test allows it (indeterminate.closed_bases_suffice), else by the row-subset scan.
    if n_cand <= chunk:
        prediction, _ = predict_candidates(
            system, enumerate_modes(n_c, k), mu_arr, tol=tol, singular_tol=singular_tol,
            indeterminate=indeterminate, max_subsets=max_subsets,
            relaxed_from_candidates=None,
        )
        return prediction
    from_candidates = indeterminate is not False and closed_bases_suffice(system)
    # Streamed: the kinematic stage chunk by chunk, keeping the admissible and boundary
    # candidates (same arithmetic per candidate; eq. 24's LU does not see its batch).
    kept, singular, n_chunks = [], 0, 0
    relaxed = RelaxedCodes(system, tol) if from_candidates else None
    for codes in iter_candidate_codes(n_c, k, chunk):
        n_chunks += 1
        kin = kinematic_stage(system, candidates_from_codes(codes, k), tol=tol,
                              singular_tol=singular_tol)
        singular += int(np.count_nonzero(~kin.nonsingular))
        kept.append(codes[kin.ok | kin.boundary])
        if relaxed is not None:
            relaxed.add(kin)
    prediction, _ = predict_candidates(
        system, candidates_from_codes(np.concatenate(kept), k), mu_arr, tol=tol,
        singular_tol=singular_tol, indeterminate=indeterminate, max_subsets=max_subsets,
        extra_degenerate=singular, method=f"exhaustive, streamed in {n_chunks} chunks",
        relaxed=relaxed,
    )
    return prediction


class RelaxedCodes:
    """Relaxed-utility candidates read off determinate candidates' velocities (valid when
    :func:`planner.predict.indeterminate.closed_bases_suffice` holds and every eq. (49)
    candidate is added): :func:`planner.predict.indeterminate.codes_from_velocities`."""

    def __init__(self, system: System, tol: float) -> None:
        self.system, self.k, self.tol = system, system.dof, tol
        eq = equilibrated_kinematics(system)
        self.row, self.gen = eq.row, GEN_TOL * eq.b_scale
        self.strict: np.ndarray | None = None  # generation_thresholds, when first needed
        self.found: set[bytes] = set()
        self.codes: list[np.ndarray] = []
        self.limit = ""

    def add(self, kin: KinematicStage) -> None:
        """Read the modes off one kinematic stage (singular candidates' NaN rows never vanish)."""
        self.add_velocities(kin.v)

    def add_velocities(self, v: np.ndarray) -> None:
        """Read the modes off relative velocities ``v (m, 2 n_c)`` (eq. 5) of nonsingular
        candidates."""
        if not v.shape[0]:
            return
        ve = v / self.row
        # At generic velocities exactly k rows vanish: nothing to read off (the common case).
        if np.maximum.reduce(np.add.reduce(np.abs(ve) <= self.gen, axis=1)) <= self.k:
            return
        if self.strict is None:
            self.strict = generation_thresholds(self.system, self.tol)[0]
        self.limit = codes_from_velocities(
            ve, self.k, self.strict, self.gen, self.found, self.codes) or self.limit


def predict_candidates(
    system: System,
    cand: CandidateSet,
    mu_arr: np.ndarray,
    *,
    tol: float,
    singular_tol: float,
    indeterminate: bool | None,
    max_subsets: int = DEFAULT_MAX_ROW_SUBSETS,
    extra_degenerate: int = 0,
    method: str = "exhaustive",
    relaxed_from_candidates: bool | None = False,
    relaxed: RelaxedCodes | None = None,
) -> tuple[Prediction, int]:
    """Kinematic then force stage on the candidates ``cand`` and the :class:`Prediction`
    (eqs. 23-28); also the number of candidates that reached the force stage.

    ``cand`` is every eq. (49) candidate for :func:`feasible_modes`, and the candidates that
    survive the pruning for :func:`planner.predict.search.search_modes` or the streamed
    enumeration (same arithmetic per candidate, same assembly); ``candidates`` in the result is
    always the eq. (49) count.  ``extra_degenerate`` singular candidates were dropped before;
    ``indeterminate`` and ``max_subsets`` as in :func:`feasible_modes`.  The relaxed-utility
    candidates come from ``relaxed`` (collected over streamed chunks), from ``cand``'s own
    velocities (``relaxed_from_candidates``: ``cand`` is every eq. (49) candidate and the
    structural test holds; None: ``cand`` is every eq. (49) candidate, apply the structural
    test, helped by the kinematic stage's determinants), or else from the row-subset scan.
    """
    kin = kinematic_stage(system, cand, tol=tol, singular_tol=singular_tol)
    idx = kin.ok.nonzero()[0]
    fs = force_stage(system, cand, idx, kin.xi.take(idx, axis=0), mu_arr, tol=tol,
                     singular_tol=singular_tol)
    f_ok = fs.nonsingular[0]
    kin_margin = kin.margin.take(idx)
    margin = np.minimum(fs.margin[0], kin_margin)
    feasible = f_ok & (margin >= -tol)
    # Overflow check (qdot of admissible candidates and c_A of nonsingular Q_AI must be finite).
    # A non-finite qdot makes every v = K z - rhs non-finite, so an admissible candidate with
    # one has kinematic margin +inf; the largest force of a pair is finite when its c_A is.
    # In the common case neither shows anything; else look closer.
    if not (np.maximum.reduce(kin_margin, initial=-np.inf) < np.inf
            and math.isfinite(np.maximum.reduce(fs.force_scale[0], axis=None, initial=0.0))):
        finite = np.isfinite(kin.qdot[idx]).all(axis=1) & np.isfinite(fs.c_A[0]).all(axis=1)
        if np.any(f_ok & ~finite):
            raise DegenerateError(
                "numerical overflow while solving eqs. (24)/(26): expected inputs whose "
                "magnitudes fit in double precision products (rescale lengths, forces or speeds)"
            )
    codes, xi = cand.codes, kin.xi
    modes = []
    for j in feasible.nonzero()[0].tolist():
        i = int(idx[j])
        m_j = float(margin[j])
        modes.append(
            FeasibleMode(
                mode=Mode(tuple(codes[i].tolist()), tuple(xi[i].tolist())),
                qdot=kin.qdot[i].copy(),
                joint_velocities=kin.joint_velocities_of(i),
                contact_velocities=kin.v[i].reshape(-1, 2).copy(),
                contact_forces=fs.contact_forces[0, j].copy(),
                joint_efforts=fs.joint_efforts[0, j].copy(),
                margin=m_j,
                on_boundary=abs(m_j) <= tol,
            )
        )
    boundary = boundary_modes_of(system, cand, kin, mu_arr, tol=tol, singular_tol=singular_tol)
    degenerate = (extra_degenerate + len(cand) - int(np.count_nonzero(kin.nonsingular))
                  + len(idx) - int(np.count_nonzero(f_ok)))
    if relaxed_from_candidates is None:
        relaxed_from_candidates = indeterminate is not False and closed_bases_suffice(system, kin)
    if indeterminate is not False and relaxed is None and relaxed_from_candidates:
        relaxed = RelaxedCodes(system, tol)
        relaxed.add(kin)
    prediction = finish_prediction(
        system, mu_arr, tuple(modes), boundary, degenerate, kin.velocity_scale,
        tol=tol, singular_tol=singular_tol, indeterminate=indeterminate,
        max_subsets=max_subsets, relaxed=relaxed, method=method,
    )
    return prediction, len(idx)


def finish_prediction(
    system: System,
    mu_arr: np.ndarray,
    modes: tuple[FeasibleMode, ...],
    boundary: tuple[Mode, ...],
    degenerate: int,
    velocity_scale: float,
    *,
    tol: float,
    singular_tol: float,
    indeterminate: bool | None,
    max_subsets: int,
    relaxed: RelaxedCodes | None,
    method: str,
    relaxed_kinematics: tuple[tuple[IndeterminateKinematics, ...], str] | None = None,
) -> Prediction:
    """The relaxed-utility modes (from ``relaxed`` or the row-subset scan), the status, the
    reason and the limits: the :class:`Prediction` of the determinate results ``modes``,
    ``boundary``, ``degenerate`` (shared by the single and the batch API).
    ``relaxed_kinematics``: the admissible relaxed-utility candidates and a limit message,
    already found (batch API)."""
    extra: tuple[FeasibleMode, ...] = ()
    limits: list[str] = []
    if indeterminate is False:
        limits.append(INDETERMINATE_OFF)
    else:
        if relaxed_kinematics is not None:
            kinematics, limit = relaxed_kinematics
        elif relaxed is not None:
            kinematics = tuple(indeterminate_kinematics_of(
                system, relaxed.codes, tol=tol, singular_tol=singular_tol)) if relaxed.codes else ()
            limit = relaxed.limit
        else:
            scan = scan_indeterminate(
                system, tol=tol, singular_tol=singular_tol,
                max_subsets=max_subsets if indeterminate is None else 2**63,
            )
            kinematics, limit = scan.kinematics, scan.limit
        if limit:
            limits.append(limit)
        if kinematics:
            extra = tuple(indeterminate_modes(system, mu_arr, tol=tol,
                                              singular_tol=singular_tol, kinematics=kinematics))
    n_feasible = len(modes) + len(extra)
    n_cand = candidate_count(system.n_contacts, system.dof)
    boundary = frictionless_duplicates_removed(boundary, {m.label for m in modes + extra}, mu_arr)
    unbalanced = None
    if n_cand == 0:
        status = Status.NO_CANDIDATES
        reason = (
            f"the utility conditions (29)-(32) admit no mode: {system.n_contacts} contact(s) "
            f"cannot supply 2 n_R + n_S = {system.dof} kinematic constraints"
        )
    elif velocity_scale == 0.0 and n_feasible:
        status = Status.AT_REST
        reason = (f"every commanded joint velocity is zero: nothing slides or breaks; "
                  f"{n_feasible} static equilibrium mode(s) hold")
    elif velocity_scale == 0.0:
        from planner.predict.unbalanced import describe_motion, unbalanced_load

        status = Status.MOVING
        unbalanced = unbalanced_load(system, mu_arr)
        reason = ("nothing is driven and no static equilibrium holds: the load moves it "
                  "(accelerating; the quasistatic modes do not apply): "
                  + describe_motion(system, unbalanced))
    elif n_feasible == 0:
        status = Status.JAMMED
        reason = "no candidate mode is feasible" + (
            f" ({degenerate} candidate(s) violate the rank conditions (30)-(32))"
            if degenerate else ""
        )
    else:
        status = Status.UNIQUE if n_feasible == 1 else Status.AMBIGUOUS
        reason = f"{n_feasible} feasible mode(s)"
    if boundary or any(m.on_boundary for m in modes + extra):
        reason += "; some decisions are within tolerance of a boundary"
    if limits:
        reason += "; NOT COMPLETE: " + "; ".join(limits)
    return Prediction(
        status=status,
        candidates=n_cand,
        modes=modes,
        indeterminate_modes=extra,
        boundary_modes=boundary,
        degenerate=degenerate,
        tol=tol,
        mu=np.array(mu_arr, dtype=float),
        reason=reason,
        limits=tuple(limits),
        method=method,
        unbalanced=unbalanced,
    )

