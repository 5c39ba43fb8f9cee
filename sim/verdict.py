"""One verdict for every simulator check: observed behaviour against the planner's prediction.

Every check -- a paper example run, the ruler's switch positions, a hand plan run, a scenario,
``qsplan validate`` -- ends in one :class:`Verdict` whose :class:`Outcome` is

* ``agreed``: the run shows what the prediction says (within the documented tolerances);
* ``disagreed``: it shows something else (a rival mode, the workpiece escaping, a switch off
  its predicted place): a real finding about the prediction;
* ``inconclusive``: the run cannot tell (too few judged steps, a measured engine limitation such
  as creep above the sliding threshold); never a pass, never a silent fail;
* ``fault``: simulator trouble (:class:`sim.run.Fault`, whose ``kind`` stays a field); the run
  says nothing about the prediction.

Scenarios and plan runs state what they :class:`Expect` (``agree``, ``disagree`` for negative
controls, ``info`` for scenarios that only draw); :meth:`Verdict.held` says whether the outcome
matched the expectation (a fault or an inconclusive run never holds).

Observed modes are the planner's :class:`planner.model.modes.Mode` objects (or :data:`JAM`,
Fig. 3's "Jam": no quasistatic motion), compared by value, never re-parsed from strings.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from enum import Enum
from typing import Any, Final, Literal

from planner.errors import InputError
from planner.model.modes import Mode
from sim.run import Fault, FaultKind

#: The observed "mode" of a run whose workpiece no longer follows any quasistatic motion.
JAM: Final = "JAM"
#: What the classifier reports per step: a contact mode, or a jam.
ObservedMode = Mode | Literal["JAM"]

#: Fraction of judged steps that must show a predicted mode (paper examples, hand plans).
MODE_FRACTION_REQUIRED = 0.95
#: Hand plans: final workpiece position error allowed, as a fraction of the predicted travel.
POSE_TOLERANCE_OF_TRAVEL = 0.02
#: Observed mean workpiece twist vs the predicted mode's ``qdot``: largest error
#: ``|q_obs - q_pred|_L / max(|q_pred|_L, drive speed)`` (:func:`sim.classify.twist_error`;
#: docs/simulation.md, "Judging a run"): 10 % of the predicted twist, or of the drive speed
#: where the workpiece is predicted to move slower (twice the classifier's slip threshold).
TWIST_TOLERANCE = 0.1
#: Observed mean contact forces vs the nearest member of the predicted mode's certificate
#: family: largest ``|c_obs - c|`` component over the run's force scale (docs/simulation.md).
FORCE_TOLERANCE = 0.1
#: Forces are judged only while the workpiece is within this fraction of its size (``L``-norm
#: of the pose change) of the configuration the certificate is for.
FORCE_DRIFT_LIMIT = 0.01


class Outcome(str, Enum):
    """What a simulator check found (module docstring)."""

    AGREED = "agreed"
    DISAGREED = "disagreed"
    INCONCLUSIVE = "inconclusive"
    FAULT = "fault"


class Expect(str, Enum):
    """What a scenario or plan run is expected to show."""

    AGREE = "agree"
    DISAGREE = "disagree"
    INFO = "info"

    @classmethod
    def parse(cls, value: str | Expect) -> Expect:
        try:
            return cls(value)
        except ValueError:
            raise InputError(f"expect: expected one of {', '.join(e.value for e in cls)}, "
                             f"got {value!r}") from None


def mode_label(mode: ObservedMode) -> str:
    """``"R1 S-2 B3"`` or ``"JAM"``."""
    return mode if isinstance(mode, str) else mode.label


def count_labels(observed: Sequence[ObservedMode]) -> tuple[tuple[str, int], ...]:
    """``((label, steps), ...)`` sorted by label."""
    out: dict[str, int] = {}
    for o in observed:
        lab = mode_label(o)
        out[lab] = out.get(lab, 0) + 1
    return tuple(sorted(out.items()))


@dataclass(frozen=True)
class PlanMeasures:
    """What a hand plan run measured besides the mode agreement.

    ``claim``: the plan's claimed mode; ``claim_fraction`` / ``predicted_fraction`` in [0, 1]:
    judged steps in the claim / in the waypoint interval's predicted set; ``final_error`` [m]
    distance of the simulated and predicted workpiece positions at the last waypoint;
    ``travel`` [m] predicted path length; ``final_angle_error`` [rad];
    ``max_error_of_travel``: largest waypoint position error / travel; ``waypoint_observed``:
    per hold interval the most frequent observed label.
    """

    claim: Mode
    claim_fraction: float
    predicted_fraction: float
    final_error: float
    travel: float
    final_angle_error: float
    max_error_of_travel: float
    waypoint_observed: tuple[str, ...]

    @property
    def final_error_of_travel(self) -> float:
        return self.final_error / self.travel

    def to_dict(self) -> dict[str, Any]:
        return {
            "claim": self.claim.label,
            "claim_fraction": self.claim_fraction,
            "predicted_fraction": self.predicted_fraction,
            "final_error_m": self.final_error,
            "travel_m": self.travel,
            "final_error_of_travel": self.final_error_of_travel,
            "final_angle_error_rad": self.final_angle_error,
            "max_error_of_travel": self.max_error_of_travel,
            "waypoint_observed": list(self.waypoint_observed),
        }


@dataclass(frozen=True)
class MotionMeasures:
    """Observed workpiece motion and contact forces against a predicted mode's certificate.

    ``twist_observed`` (3 n_b,) [m/s, m/s, rad/s] mean twist of each workpiece frame's origin
    over the judged stretch (:func:`sim.judge.twist_stretch`); ``reference``: the predicted
    mode compared with (the most observed one consistent with the run, else the closest in
    twist);
    ``twist_predicted`` its ``qdot`` at the run's speed; ``twist_error``: error relative to
    ``max(|qdot|, drive speed)`` (:data:`TWIST_TOLERANCE`); ``twist_cosine``: cosine of the
    angle between the two (rotation weighted by ``length_scale``); ``twist_size_ratio``:
    observed / predicted size; ``force_error``: largest component of ``c_obs - c`` over the
    force scale, ``c`` the nearest member of the reference mode's certificate family (its
    certificate when force-determinate; None when no step was in the mode);
    ``forces_observed`` (n_c, 2) [N] mean ``(c_in, c_it)`` over the steps in the reference
    mode.
    """

    twist_observed: tuple[float, ...]
    reference: str | None = None
    twist_predicted: tuple[float, ...] | None = None
    twist_error: float | None = None
    twist_cosine: float | None = None
    twist_size_ratio: float | None = None
    force_error: float | None = None
    forces_observed: tuple[tuple[float, float], ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return {
            "reference_mode": self.reference,
            "twist_observed": list(self.twist_observed),
            "twist_predicted": list(self.twist_predicted) if self.twist_predicted else None,
            "twist_error": self.twist_error, "twist_cosine": self.twist_cosine,
            "twist_size_ratio": self.twist_size_ratio, "force_error_of_load": self.force_error,
            "forces_observed_N": [list(c) for c in self.forces_observed],
        }


@dataclass(frozen=True)
class Verdict:
    """The one result type of a simulator check.

    ``outcome``; ``reasons``: why (one line each; :attr:`reason` joins them); ``agreement`` in
    [0, 1]: fraction of the judged steps (or predicted events) that matched; ``judged_steps``:
    how many steps (or events) were actually judged; ``observed_counts``: label -> judged steps;
    ``fault``: the simulator fault behind a ``fault`` outcome; ``plan``: hand plan measures.
    """

    outcome: Outcome
    reasons: tuple[str, ...]
    agreement: float = 0.0
    judged_steps: int = 0
    observed_counts: tuple[tuple[str, int], ...] = ()
    fault: Fault | None = None
    plan: PlanMeasures | None = None
    motion: MotionMeasures | None = None

    def __post_init__(self) -> None:
        if not 0.0 <= self.agreement <= 1.0:
            raise InputError(f"agreement: expected a fraction in [0, 1], got {self.agreement}")

    @property
    def reason(self) -> str:
        return "; ".join(self.reasons)

    def held(self, expect: Expect) -> bool:
        """True when the outcome is what ``expect`` asks for (never for a fault or an
        inconclusive run; ``info`` expects no judgement)."""
        if self.outcome in (Outcome.FAULT, Outcome.INCONCLUSIVE):
            return False
        if expect is Expect.INFO:
            return True
        return (self.outcome is Outcome.AGREED) == (expect is Expect.AGREE)

    def to_dict(self) -> dict[str, Any]:
        """The verdict fields of summary.json (``status`` is the outcome)."""
        out: dict[str, Any] = {
            "status": self.outcome.value,
            "agreement": self.agreement,
            "judged_steps": self.judged_steps,
            "reason": self.reason,
            "reasons": list(self.reasons),
            "observed_counts": dict(self.observed_counts),
            "fault": self.fault.reason if self.fault is not None else None,
            "fault_kind": self.fault.kind.value if self.fault is not None else None,
        }
        if self.plan is not None:
            out.update(self.plan.to_dict())
        if self.motion is not None:
            out["motion"] = self.motion.to_dict()
        return out


def fault_verdict(fault: Fault, before: Verdict | None = None) -> Verdict:
    """The verdict of a run that ended in a simulator fault. ``before``: the judgement of the
    steps recorded before the fault; when it is ``disagreed`` the run had already left the plan
    (a rival mode, the workpiece off its path) and the fault is what followed -- the escaping
    workpiece leaving the scene or pushed into a finger (``left_scene``, ``penetration``): the
    verdict is ``disagreed`` with the observed modes up to the event and the fault as the
    event. Otherwise (and always for NaN, engine alarms and contacts missing at the start:
    simulator trouble whatever the run showed before) it is a ``fault``."""
    if (before is not None and before.outcome is Outcome.DISAGREED
            and fault.kind in (FaultKind.LEFT_SCENE, FaultKind.PENETRATION)):
        return replace(before, reasons=before.reasons + (
            f"the run left the plan, then ended: {fault.reason}",), fault=fault)
    return Verdict(Outcome.FAULT, (fault.reason,), fault=fault)
