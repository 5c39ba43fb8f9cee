"""Plan a hand file (``qsplan plan``): its ``segment`` section as one segment, or the whole task
to its ``goal`` (docs/planning.md).  The result is always a :class:`planner.plan.model.Plan`."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.files.hand_file import HandFile, load_hand_file
from planner.model.hand import Hand
from planner.model.validation import FrictionValue, friction_interval, validation_frictions
from planner.plan.load_margins import tolerated
from planner.plan.model import Plan
from planner.plan.policies import DEFAULT_POLICY
from planner.plan.segment_planner import plan_segment
from planner.plan.task import TaskOptions, plan_task
from planner.plan.task_contacts import contact_dict

#: Task search defaults when the hand file has no ``segment`` section (docs/planning.md).
TASK_SPEED = 0.02  # rad/s or m/s
TASK_STEPS = 120


def default_mu_model(mu: Any) -> str:
    """The friction model a friction description asks for: ``independent`` (one coefficient per
    contact, each in its own interval) when it gives one interval per contact -- a list or
    array of ``(lo, hi)`` pairs, equal or not --, ``common`` (one coefficient shared by every
    contact, the paper's model) for one interval or one number."""
    try:
        shape = np.shape(np.asarray(mu, dtype=float))
    except (TypeError, ValueError):  # ragged: friction_interval names the problem later
        return "common"
    return "independent" if len(shape) == 2 and shape[0] > 1 else "common"


def used_mu_model(model: str, plan: Plan) -> str:
    """The model a plan's guarantee actually holds for: a segment with other than one
    effort-controlled joint is guaranteed over the box of per-contact intervals
    (:func:`planner.plan.polytope.torque_region`, sound for both models), so a ``common``
    request whose plan has such a segment is recorded ``independent`` (what was checked)."""
    if model == "common" and any(len(seg.effort_joints) != 1 for seg in plan.segments):
        return "independent"
    return model


def _default_interval(hf: HandFile) -> tuple[float, float] | None:
    """The interval of contacts on bodies ``mu.bodies`` does not list: ``mu.interval`` when it
    is one pair, else (with ``mu.bodies``) the hull of the bodies' intervals -- wider than each,
    so a guarantee over it holds for each (a wider friction box only shrinks the guaranteed
    set)."""
    if hf.mu_interval is not None and len(hf.mu_interval) == 1:
        return hf.mu_interval[0]
    if hf.mu_bodies:
        ivs = list(hf.mu_bodies.values())
        return (min(a for a, _ in ivs), max(b for _, b in ivs))
    return None


def body_frictions(plan: Plan, hf: HandFile, bodies: Mapping[str, tuple[float, float]],
                   default: tuple[float, float] | None, listed: Any) -> tuple[FrictionValue, ...]:
    """Friction values to simulate a plan made with ``mu.bodies`` at: one coefficient per
    contact of the plan's contact union (every segment's contacts in order of first
    appearance, the order the simulators use), each from its body's value in a ``mu.validate``
    entry (an object body -> coefficient; a number is every body's).  Entries outside a
    contact's interval are dropped; when none is left, the friction box's lower corner, centre
    and upper corner."""
    union: list[Any] = []
    for seg in plan.segments:
        union += [c for c in seg.contacts if c not in union]
    if not union:
        union = [contact_dict(hf.hand, c) for c in hf.hand.contacts]
    names = [_dict_body(hf.hand, c) for c in union]
    ivs = [bodies[n] if n in bodies else default or (0.0, 0.0) for n in names]
    lo = np.array([a for a, _ in ivs])
    hi = np.array([b for _, b in ivs])
    out: list[FrictionValue] = []
    for m in listed:
        if isinstance(m, dict):  # every body of the union must be given
            v = np.array([m.get(n, np.nan) for n in names], dtype=float)
        else:
            v = np.full(len(names), float(m))
        if np.all(np.isfinite(v)) and np.all(v >= lo - 1e-12) and np.all(v <= hi + 1e-12):
            out.append(tuple(float(x) for x in v))
    if out:
        return tuple(out)
    return tuple(tuple(float(x) for x in v) for v in (lo, 0.5 * (lo + hi), hi))


def _dict_body(hand: Hand, c: Mapping[str, Any]) -> str:
    """:meth:`Hand.body_name` of a contact object (docs/two-finger-task.md)."""
    if c["kind"] in ("palm", "surface"):
        return "palm" if c["kind"] == "palm" else str(c["surface"])
    return hand.fingers[int(c["finger"])].name


def plan_hand(source: str | os.PathLike[str] | HandFile, *, mu: Any = None,
              model: str | None = None, policy: str = DEFAULT_POLICY,
              control: tuple[int, ...] | None = None, waypoints: int | None = None,
              max_expansions: int | None = None, validate_mu: Any = None,
              margins: bool | None = None) -> Plan:
    """Plan the hand file ``source`` (a path, or a loaded :class:`HandFile`).

    With a ``goal``: the task search (:func:`planner.plan.task.plan_task`) with the ``segment``
    section's joint-rate magnitude, ``max_time`` and ``steps``.  Else its ``segment`` section
    with :func:`planner.plan.segment_planner.plan_segment` (every control partition, any
    number of effort-controlled joints; ``control`` the velocity-controlled joints, default
    any; the band curves of Figures 10-13 with one effort joint).  ``mu``: the friction interval
    (``(lo, hi)``, one pair per contact, or a number; default the file's ``mu.interval``);
    ``model``: ``common`` or ``independent`` (default :func:`default_mu_model` of the friction
    used; the plan records :func:`used_mu_model`); ``policy``: one of
    :data:`planner.plan.policies.POLICIES` (default ``smooth``), ``least-effort:M`` or
    ``rival:MODE``; ``waypoints``: that many evenly spaced per segment (default the file's
    ``segment.waypoints`` when given, else the spacing rule, :mod:`planner.plan.spacing`);
    ``validate_mu``: friction values for the simulators (default the file's ``mu.validate``
    values inside the interval); ``margins``: also find the mass and centre-of-mass
    uncertainty the commands tolerate (:func:`planner.plan.load_margins.tolerated`, written in
    ``extra["uncertainty"]``; default: when the file has an ``uncertainty`` section).

    Raises :class:`planner.errors.DegenerateError` when a single segment has no guaranteed
    plan (with every partition's reason); a task that stops short is a partial plan
    (``reached`` False) instead.  :class:`InputError` for bad input."""
    hf = source if isinstance(source, HandFile) else load_hand_file(source)
    name = Path(source).name if not isinstance(source, HandFile) else str(
        hf.data.get("name", "hand"))
    bodies = dict(hf.mu_bodies) if mu is None else {}
    default = _default_interval(hf) if mu is None else None
    if mu is None:
        if bodies:
            mu = [bodies.get(hf.hand.body_name(c), default) for c in hf.hand.contacts]
            if any(m is None for m in mu):
                missing = sorted({hf.hand.body_name(c) for c in hf.hand.contacts
                                  if hf.hand.body_name(c) not in bodies})
                raise InputError(f"{name}: expected a friction interval for the bodies "
                                 f"{missing} (mu.bodies or mu.interval), got none")
            mu = [tuple(m) for m in mu]
        elif hf.mu_interval is None:
            raise InputError(f"{name}: expected a friction interval (mu.interval in the file, "
                             "or --mu), got none")
        else:
            mu = hf.mu_interval[0] if len(hf.mu_interval) == 1 else list(hf.mu_interval)
    if model is None:
        model = default_mu_model(mu)
    lo, hi = friction_interval(mu, hf.hand.n_contacts)
    listed = hf.validate_mu if validate_mu is None else validate_mu
    validate = validation_frictions([m for m in listed if not isinstance(m, dict)], lo, hi)
    raw = hf.data.get("segment")
    n_wp = waypoints if waypoints is not None else (
        raw.get("waypoints") if isinstance(raw, dict) else None)
    seg = hf.segment
    if hf.goal is not None:
        if policy != DEFAULT_POLICY or control is not None:
            raise InputError(f"policy/control: expected the defaults for a whole task "
                             f"({DEFAULT_POLICY}, every partition), got {policy!r} and "
                             f"{control!r}")
        if not bodies and not (np.all(lo == lo[0]) and np.all(hi == hi[0])):
            raise InputError("mu: expected one friction interval for every contact of a task "
                             "(its contact set changes), got one per contact "
                             f"{[(float(a), float(b)) for a, b in zip(lo, hi)]}")
        opts = TaskOptions(speed=abs(seg.speed) if seg else TASK_SPEED,
                           mu=default if bodies and default else (lo[0], hi[0]),
                           friction=bodies,
                           model=model, max_time=seg.max_time if seg else 60.0,
                           steps=seg.steps if seg else TASK_STEPS, waypoints=n_wp,
                           max_expansions=max_expansions or 40)
        plan = plan_task(hf.hand, hf.q0, hf.goal, opts, data=hf.data, validate_mu=validate)
        if bodies:
            plan = replace(plan, validate_mu=body_frictions(plan, hf, bodies, default, listed))
        return with_margins(replace(
            plan, mu_model=used_mu_model(model, plan),
            notes=f"source {name}" + (f"; {plan.notes}" if plan.notes else "")), hf, margins)
    if seg is None:
        raise InputError(f"{name}: expected a 'goal' or a 'segment' section to plan, got "
                         "neither")
    segment = plan_segment(hf.hand, hf.q0, data=hf.data, drive=seg.drives, speed=seg.speeds,
                           mode=seg.mode, mu=mu, model=model, policy=policy, control=control,
                           waypoints=n_wp, max_time=seg.max_time, steps=seg.steps, curves=True)
    ivs = tuple((float(a), float(b)) for a, b in zip(lo, hi))
    plan = Plan(hand=dict(hf.data), segments=(segment,), mu_model=model,
                mu_intervals=ivs[:1] if len(set(ivs)) == 1 else ivs, validate_mu=validate,
                notes=f"source {name}")
    if bodies:
        plan = replace(plan, validate_mu=body_frictions(plan, hf, bodies, default, listed))
    return with_margins(replace(plan, mu_model=used_mu_model(model, plan)), hf, margins)


def with_margins(plan: Plan, hf: HandFile, margins: bool | None) -> Plan:
    """``plan`` with ``extra["uncertainty"]``: the file's mass / centre-of-mass set (``set``,
    None when not given) and what the commands tolerate (``tolerated``,
    :func:`planner.plan.load_margins.tolerated`) -- when ``margins``, or by default when the
    file has an ``uncertainty`` section; else ``plan`` unchanged."""
    if not (margins or (margins is None and hf.hand.load_set is not None)) or not plan.segments:
        return plan
    ls = hf.hand.load_set
    found = tolerated(plan)
    extra = {**plan.extra, "uncertainty": {"set": None if ls is None else ls.to_dict(),
                                           "tolerated": found.to_dict()}}
    return replace(plan, extra=extra)
