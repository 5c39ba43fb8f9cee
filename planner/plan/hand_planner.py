"""Plan a hand file (``qsplan plan``): its ``segment`` section as one segment, or the whole task
to its ``goal`` (docs/planning.md).  The result is always a :class:`planner.plan.model.Plan`."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.files.hand_file import HandFile, load_hand_file
from planner.model.validation import friction_interval, validation_frictions
from planner.plan.model import Plan
from planner.plan.policies import DEFAULT_POLICY
from planner.plan.segment_planner import plan_segment
from planner.plan.task import TaskOptions, plan_task

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


def plan_hand(source: str | os.PathLike[str] | HandFile, *, mu: Any = None,
              model: str | None = None, policy: str = DEFAULT_POLICY,
              control: tuple[int, ...] | None = None, waypoints: int | None = None,
              max_expansions: int | None = None, validate_mu: Any = None) -> Plan:
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
    values inside the interval).

    Raises :class:`planner.errors.DegenerateError` when a single segment has no guaranteed
    plan (with every partition's reason); a task that stops short is a partial plan
    (``reached`` False) instead.  :class:`InputError` for bad input."""
    hf = source if isinstance(source, HandFile) else load_hand_file(source)
    name = Path(source).name if not isinstance(source, HandFile) else str(
        hf.data.get("name", "hand"))
    if mu is None:
        if hf.mu_interval is None:
            raise InputError(f"{name}: expected a friction interval (mu.interval in the file, "
                             "or --mu), got none")
        mu = hf.mu_interval[0] if len(hf.mu_interval) == 1 else list(hf.mu_interval)
    if model is None:
        model = default_mu_model(mu)
    lo, hi = friction_interval(mu, hf.hand.n_contacts)
    validate = validation_frictions(hf.validate_mu if validate_mu is None else validate_mu,
                                    lo, hi)
    raw = hf.data.get("segment")
    n_wp = waypoints if waypoints is not None else (
        raw.get("waypoints") if isinstance(raw, dict) else None)
    seg = hf.segment
    if hf.goal is not None:
        if policy != DEFAULT_POLICY or control is not None:
            raise InputError(f"policy/control: expected the defaults for a whole task "
                             f"({DEFAULT_POLICY}, every partition), got {policy!r} and "
                             f"{control!r}")
        if not (np.all(lo == lo[0]) and np.all(hi == hi[0])):
            raise InputError("mu: expected one friction interval for every contact of a task "
                             "(its contact set changes), got one per contact "
                             f"{[(float(a), float(b)) for a, b in zip(lo, hi)]}")
        opts = TaskOptions(speed=abs(seg.speed) if seg else TASK_SPEED, mu=(lo[0], hi[0]),
                           model=model, max_time=seg.max_time if seg else 60.0,
                           steps=seg.steps if seg else TASK_STEPS, waypoints=n_wp,
                           max_expansions=max_expansions or 40)
        plan = plan_task(hf.hand, hf.q0, hf.goal, opts, data=hf.data, validate_mu=validate)
        return replace(plan, mu_model=used_mu_model(model, plan),
                       notes=f"source {name}" + (f"; {plan.notes}" if plan.notes else ""))
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
    return replace(plan, mu_model=used_mu_model(model, plan))
