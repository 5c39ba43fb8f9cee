"""A plan run at points of its uncertainty set (docs/planning.md, "Validating at points of the
set"): the plan moved to the point (:func:`planner.plan.set_points.plan_at`: the scene simulates
the workpiece's mass, centre of mass, load and moved contact geometry there, and the planner
predicts every waypoint's modes there), run through the one pipeline
(:func:`scenarios.runs.validate_plan`), its verdict
held against what the planner predicts at the point:

* ``agree`` when the claim is the only predicted mode over every hold interval of every segment;
* ``disagree`` when, in some segment, the claim is not predicted at all on more than
  ``1 - MODE_FRACTION_REQUIRED`` of its duration: the judge requires the claim on
  :data:`sim.verdict.MODE_FRACTION_REQUIRED` of the segment, which the model says it cannot show;
* ``info`` otherwise (the claim shares the point with a rival: either may be observed).

A point of the set whose prediction is not ``agree`` contradicts the plan's guarantee (the plan
says the claim is the only mode everywhere in the set): it is reported as a failure of the plan
(:attr:`SetRun.failed`).  A point outside the set may fail: its run only says whether the planner's
prediction there held.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from planner.model.validation import FrictionValue
from planner.plan.model import Plan
from planner.plan.set_points import SetAxis, SetPoint, claim_shares, plan_at
from sim.jobs import RunResult
from sim.verdict import MODE_FRACTION_REQUIRED, Expect


@dataclass(frozen=True, eq=False)
class SetRun:
    """One plan run at one ``point`` of the set: ``expect`` (module docstring) from the planner's
    prediction there (``shares`` per segment ``(only, absent)``,
    :func:`planner.plan.set_points.claim_shares`), the ``result``, and ``early`` the words of
    each segment whose motion ends at an event before its planned end there (the run and the
    judge end that segment at it: :func:`planner.plan.contact_moves.moved_path`)."""

    point: SetPoint
    expect: Expect
    shares: tuple[tuple[float, float], ...]
    result: RunResult
    early: tuple[str, ...] = ()

    @property
    def matched(self) -> bool:
        """The run showed what the planner predicts at the point (never for a fault)."""
        return self.result.summary.passed

    @property
    def failed(self) -> bool:
        """A failure of the plan: a point of the set whose prediction contradicts the
        guarantee, or whose run did not show the claim."""
        return self.point.inside and (self.expect is not Expect.AGREE or not self.matched)


def expectation(shares: Sequence[tuple[float, float]]) -> Expect:
    """``agree`` / ``disagree`` / ``info`` from the per-segment shares (module docstring)."""
    if all(only >= 1.0 for only, _ in shares):
        return Expect.AGREE
    if any(absent > 1.0 - MODE_FRACTION_REQUIRED for _, absent in shares):
        return Expect.DISAGREE
    return Expect.INFO


def segment_frictions(plan: Plan, mu: FrictionValue) -> list[Any]:
    """Per segment the run's friction on its own contacts: ``mu`` itself (one coefficient), or
    the entries of the plan's contact union (:func:`sim.schedule.plan_layout`) it holds."""
    if isinstance(mu, (int, float)):
        return [float(mu)] * len(plan.segments)
    from sim.schedule import plan_layout

    members = plan_layout(plan).members
    return [tuple(float(mu[i]) for i in m) for m in members]


def run_at_point(plan: Plan, axes: Sequence[SetAxis], point: SetPoint, engine: str,
                 mu: FrictionValue, *, name: str, source: str | None = None) -> SetRun:
    """Run ``plan`` at ``point`` in ``engine`` at friction ``mu`` (module docstring); the run's
    summary records the point in ``parameters.set_point``."""
    from scenarios.runs import validate_plan

    moved = plan_at(plan, axes, point, segment_frictions(plan, mu))
    shares = claim_shares(moved)
    expect = expectation(shares)
    record = {**point.to_dict(axes), "expect": expect.value,
              "claim_only_share": [s[0] for s in shares],
              "claim_absent_share": [s[1] for s in shares]}
    early = tuple(f"segment {k} ends at t = {a.waypoints[-1].t:.3g} s here, not "
                  f"{b.waypoints[-1].t:.3g} s: {a.event.detail}"
                  for k, (a, b) in enumerate(zip(moved.segments, plan.segments), start=1)
                  if a.waypoints[-1].t < b.waypoints[-1].t)
    if early:
        record["ends_early"] = list(early)
    res = validate_plan(moved, engine, mu, name=name, source=source, expect=expect,
                        parameters={"set_point": record})
    return SetRun(point, expect, shares, res, early)


def point_line(run: SetRun, axes: Sequence[SetAxis], engine: str, mu_text: str) -> str:
    """One line per run: the point, the planner's prediction there, the verdict and whether
    it is a failure of the plan."""
    v = run.result.verdict
    where = "inside the set" if run.point.inside else "outside the set (allowed to fail)"
    pm = v.plan
    seen = (f"claim observed {pm.claim_fraction:.1%}, final position "
            f"{pm.final_error_of_travel:.2%} of travel" if pm is not None else v.reason)
    if run.point.inside and run.expect is not Expect.AGREE:
        judged = "FAILED: the planner predicts more than the claim here, inside the set"
    elif run.matched:
        judged = "as predicted"
    else:
        judged = "FAILED" if run.point.inside else "not as predicted"
    ends = "".join(f"; {e}" for e in run.early)
    return (f"{engine} mu={mu_text} set {run.point.name} ({run.point.words(axes)}; {where}): "
            f"{v.outcome.value.upper()}, predicted {run.expect.value} -- {judged} ({seen}{ends}) "
            f"[{run.result.summary.wall_time_s:.1f} s]")
